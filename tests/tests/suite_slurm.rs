//! `lewis test` under a real scheduler: a one-node Slurm cluster started from Debian's
//! packages (`slurm-wlm`, `munge`) in a temporary folder, the suite's plan submitted as a
//! job array (`sbatch --wait --array`), merged, and compared with the one-machine report,
//! byte for byte. Every daemon the test starts is stopped when it ends, passed or not.
//!
//! The daemons run in the foreground as the test's children, on the loopback, with the
//! machine's short host name as the node: `munged` with a key of its own, `slurmctld` and
//! `slurmd` with `ProctrackType=proctrack/linuxproc` and `TaskPlugin=task/none` (no cgroups
//! to set up). Without the packages the test says so and passes, except under `CI`, where
//! it fails: CI installs them (`.ci/run`).

// Test helpers fail the test by panicking, like the tests that call them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use lewis_tests::{lewis_exe, repo_root, shared_data};

/// How long a daemon may take to answer once started.
const READY_WITHIN: Duration = Duration::from_secs(60);

/// The programs the test needs, each found in `PATH` or `/usr/sbin`.
const TOOLS: [&str; 7] = [
    "munged",
    "munge",
    "slurmctld",
    "slurmd",
    "sbatch",
    "scontrol",
    "hostname",
];

/// The daemons started, stopped (killed and awaited) when dropped, in reverse order.
struct Daemons {
    children: Vec<(String, Child)>,
}

impl Drop for Daemons {
    fn drop(&mut self) {
        while let Some((_, mut child)) = self.children.pop() {
            // SIGTERM first: slurmctld then stops its own helper (slurmscriptd) too.
            let _ = Command::new("kill")
                .args(["-TERM", &child.id().to_string()])
                .status();
            let asked = Instant::now();
            while matches!(child.try_wait(), Ok(None)) && asked.elapsed() < STOP_WITHIN {
                // A daemon's exit cannot be awaited with a deadline otherwise.
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// How long a daemon may take to stop on SIGTERM before it is killed.
const STOP_WITHIN: Duration = Duration::from_secs(10);

impl Daemons {
    fn start(&mut self, name: &str, command: &mut Command, log: &Path) {
        let out = std::fs::File::create(log).unwrap();
        let child = command
            .stdout(Stdio::from(out.try_clone().unwrap()))
            .stderr(Stdio::from(out))
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {name}: {e}"));
        self.children.push((name.to_owned(), child));
    }

    /// Panics, with the daemons' logs, when one of them has exited.
    fn check_alive(&mut self, logs: &Path) {
        for (name, child) in &mut self.children {
            if let Ok(Some(status)) = child.try_wait() {
                panic!("{name} exited ({status}):\n{}", read_logs(logs));
            }
        }
    }
}

fn read_logs(dir: &Path) -> String {
    let mut text = String::new();
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    entries.sort();
    for path in entries {
        text += &format!(
            "--- {}\n{}\n",
            path.display(),
            std::fs::read_to_string(&path).unwrap_or_default()
        );
    }
    text
}

/// `name`'s path, in `PATH` or `/usr/sbin` (where Debian puts the daemons).
fn tool(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .chain([PathBuf::from("/usr/sbin"), PathBuf::from("/sbin")])
        .map(|dir| dir.join(name))
        .find(|p| p.is_file())
}

/// Runs `command` again until it succeeds: a daemon that has just started answers on its
/// socket or port only once it is set up, and says so to no one. Bounded by
/// [`READY_WITHIN`]; the daemons are checked alive on each try.
fn until_ready(
    what: &str,
    daemons: &mut Daemons,
    logs: &Path,
    mut command: impl FnMut() -> Output,
) {
    let started = Instant::now();
    loop {
        let output = command();
        if output.status.success() {
            return;
        }
        daemons.check_alive(logs);
        assert!(
            started.elapsed() < READY_WITHIN,
            "{what} not ready within {READY_WITHIN:?}: {}\n{}",
            String::from_utf8_lossy(&output.stderr),
            read_logs(logs)
        );
        // Probing a daemon's socket: nothing to wait on but its answer.
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// A port free on the loopback now.
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn lewis_test(args: &[&str]) -> Output {
    Command::new(lewis_exe())
        .arg("test")
        .args(args)
        .current_dir(repo_root())
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .output()
        .unwrap()
}

fn said(output: &Output) -> String {
    format!(
        "status {:?}\n{}{}",
        output.status.code(),
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

#[test]
fn a_slurm_job_array_gives_the_one_machine_report_byte_for_byte() {
    let missing: Vec<&str> = TOOLS.into_iter().filter(|t| tool(t).is_none()).collect();
    if !missing.is_empty() {
        let message = format!(
            "the Slurm test needs {}: install them with `apt-get install -y slurm-wlm munge`",
            missing.join(", ")
        );
        assert!(std::env::var_os("CI").is_none(), "{message}");
        #[allow(clippy::print_stderr)]
        {
            eprintln!("not run: {message}");
        }
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let logs = root.join("logs");
    for sub in ["munge", "state", "spool", "logs"] {
        std::fs::create_dir_all(root.join(sub)).unwrap();
    }
    // munged checks that its key and folders are not open to others.
    use std::os::unix::fs::PermissionsExt as _;
    std::fs::set_permissions(root, std::fs::Permissions::from_mode(0o700)).unwrap();
    let key = root.join("munge/munge.key");
    let bytes: Vec<u8> = (0..1024_u32)
        .map(|i| u8::try_from((i.wrapping_mul(2_654_435_761) >> 13) & 0xff).unwrap())
        .collect();
    std::fs::write(&key, bytes).unwrap();
    std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o400)).unwrap();
    let socket = root.join("munge/munge.sock");

    let mut daemons = Daemons {
        children: Vec::new(),
    };
    daemons.start(
        "munged",
        Command::new(tool("munged").unwrap())
            .args(["-F", "-f"])
            .arg(format!("--socket={}", socket.display()))
            .arg(format!("--key-file={}", key.display()))
            .arg(format!("--log-file={}", logs.join("munged.log").display()))
            .arg(format!(
                "--pid-file={}",
                root.join("munge/munged.pid").display()
            ))
            .arg(format!(
                "--seed-file={}",
                root.join("munge/munged.seed").display()
            )),
        &logs.join("munged.out"),
    );
    let munge = tool("munge").unwrap();
    until_ready("munged", &mut daemons, &logs, || {
        Command::new(&munge)
            .arg("-n")
            .arg("-S")
            .arg(&socket)
            .output()
            .unwrap()
    });

    let host = String::from_utf8(
        Command::new(tool("hostname").unwrap())
            .arg("-s")
            .output()
            .unwrap()
            .stdout,
    )
    .unwrap()
    .trim()
    .to_owned();
    let user = String::from_utf8(Command::new("id").arg("-un").output().unwrap().stdout)
        .unwrap()
        .trim()
        .to_owned();
    let conf = root.join("slurm.conf");
    let at = |p: &str| root.join(p).display().to_string();
    std::fs::write(
        &conf,
        format!(
            "ClusterName=lewis\n\
             SlurmctldHost={host}(127.0.0.1)\n\
             SlurmctldPort={}\n\
             SlurmdPort={}\n\
             SlurmUser={user}\n\
             SlurmdUser={user}\n\
             AuthType=auth/munge\n\
             AuthInfo=socket={}\n\
             CredType=cred/munge\n\
             StateSaveLocation={}\n\
             SlurmdSpoolDir={}\n\
             SlurmctldPidFile={}\n\
             SlurmdPidFile={}\n\
             SlurmctldLogFile={}\n\
             SlurmdLogFile={}\n\
             ProctrackType=proctrack/linuxproc\n\
             TaskPlugin=task/none\n\
             SchedulerType=sched/builtin\n\
             SelectType=select/cons_tres\n\
             SelectTypeParameters=CR_Core\n\
             MpiDefault=none\n\
             JobCompType=jobcomp/none\n\
             AccountingStorageType=accounting_storage/none\n\
             ReturnToService=2\n\
             NodeName={host} NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN\n\
             PartitionName=lewis Nodes={host} Default=YES MaxTime=INFINITE State=UP\n",
            free_port(),
            free_port(),
            socket.display(),
            at("state"),
            at("spool"),
            at("state/slurmctld.pid"),
            at("spool/slurmd.pid"),
            at("logs/slurmctld.log"),
            at("logs/slurmd.log"),
        ),
    )
    .unwrap();
    daemons.start(
        "slurmctld",
        Command::new(tool("slurmctld").unwrap())
            .args(["-D", "-i", "-f"])
            .arg(&conf),
        &logs.join("slurmctld.out"),
    );
    daemons.start(
        "slurmd",
        Command::new(tool("slurmd").unwrap())
            .args(["-D", "-f"])
            .arg(&conf),
        &logs.join("slurmd.out"),
    );
    let scontrol = tool("scontrol").unwrap();
    until_ready("slurmctld", &mut daemons, &logs, || {
        Command::new(&scontrol)
            .arg("ping")
            .env("SLURM_CONF", &conf)
            .output()
            .unwrap()
    });

    // The suite: the reference recording and a real laser log, imported on the fly.
    let runs = root.join("runs");
    std::fs::create_dir_all(&runs).unwrap();
    std::fs::copy(
        repo_root().join("tests/data/reference/sim-goal.mcap"),
        runs.join("sim-goal.mcap"),
    )
    .unwrap();
    let log = shared_data("carmen/orebro-corrected.log.gz");
    let (runs, log) = (runs.to_str().unwrap(), log.to_str().unwrap());
    let here = root.join("here");
    let output = lewis_test(&[runs, log, "--out", here.to_str().unwrap(), "--jobs", "2"]);
    assert_eq!(output.status.code(), Some(0), "{}", said(&output));

    let array = root.join("array");
    let plan = array.join("plan.json");
    let output = lewis_test(&[runs, log, "--plan", plan.to_str().unwrap()]);
    assert!(output.status.success(), "{}", said(&output));
    let plan_text = std::fs::read_to_string(&plan).unwrap();
    let jobs = plan_text.matches("\"case\":").count();
    assert_eq!(jobs, 2, "{plan_text}");
    let script = root.join("job.sh");
    std::fs::write(
        &script,
        format!(
            "#!/bin/sh\nexec {} test --job --from {}\n",
            lewis_exe().display(),
            plan.display()
        ),
    )
    .unwrap();
    std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).unwrap();
    let output = Command::new(tool("sbatch").unwrap())
        .arg("--wait")
        .arg(format!("--array=0-{}", jobs - 1))
        .arg(format!("--chdir={}", repo_root().display()))
        .arg(format!("--output={}", logs.join("job-%a.out").display()))
        .arg(&script)
        .env("SLURM_CONF", &conf)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}\n{}",
        said(&output),
        read_logs(&logs)
    );
    let output = lewis_test(&["--merge", array.to_str().unwrap()]);
    assert_eq!(
        output.status.code(),
        Some(0),
        "{}\n{}",
        said(&output),
        read_logs(&logs)
    );
    for file in ["report.xml", "report.json", "report.html"] {
        assert!(
            std::fs::read(here.join(file)).unwrap() == std::fs::read(array.join(file)).unwrap(),
            "{file}: the job array's differs from the one machine's"
        );
    }
    drop(daemons);
}
