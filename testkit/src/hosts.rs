//! Several Lewis hosts on one machine, each isolated as a computer of its own as far as
//! Lewis can tell: its own network (a network namespace on an Ethernet segment with the
//! others), its own System V IPC, and its own shared memory (a fresh tmpfs on `/dev/shm`
//! and on `/tmp/iceoryx2`, where iceoryx2 keeps its files). The rest of the file system is
//! shared, so a test's temporary directory is seen by every host.
//!
//! The segment is a bridge (a switch) in the first host, with a veth pair (a cable) to each
//! other host: host `k` (0-based, in the order given) is `10.0.0.(k+1)/24`. The first host
//! is on the switch through `br0`, every other host through its `veth0`. Every host has a
//! route for multicast on its device of the segment. The namespaces of different
//! [`Hosts`] never meet, so every test uses the same addresses.
//!
//! Each host has an anchor: a process that made the host's IPC and mount namespaces and
//! holds them while the host lives (a `cat` reading a pipe from the test process, so it
//! ends with the test process however that ends). Every program of the host joins the
//! anchor's namespaces ([`Host::command`]), so programs started on one host one after the
//! other (`lewis up`, then `lewis status`) meet in the same shared memory.
//!
//! Needs root (`ip netns add`), iproute2, util-linux's `unshare` and `nsenter`, and bash;
//! where any is missing or forbidden, [`Hosts::new`] says why ([`Unavailable`]) and
//! [`hosts_or_skip!`](crate::hosts_or_skip) skips the test.

use std::ffi::OsStr;
use std::fmt;
use std::io::{BufRead, BufReader, Read};
use std::net::Ipv4Addr;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Mutex, Once, OnceLock};
use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;

/// Why hosts cannot be made on this machine (not root, namespaces forbidden, a tool
/// missing): a test skips on it, see [`hosts_or_skip!`](crate::hosts_or_skip).
#[derive(Debug, Clone)]
pub struct Unavailable(pub String);

impl fmt::Display for Unavailable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Unavailable {}

/// Makes [`Hosts`] of the given names (`hosts_or_skip!(&["base", "robot"])`), or, where
/// the machine forbids them ([`Unavailable`]), prints `skipped: REASON` to stderr and
/// returns from the test. Under CI (the `CI` variable set) a machine that cannot make them
/// fails the test with its reason instead: CI must set up what its tests need. Any other
/// failure panics in [`Hosts::new`].
#[macro_export]
macro_rules! hosts_or_skip {
    ($names:expr) => {
        match $crate::hosts::Hosts::new($names) {
            Ok(hosts) => hosts,
            Err(why) => $crate::skip_unless_ci!("no network namespaces for hosts: {why}"),
        }
    };
}

/// The longest a link may take to come up, or a host's processes to die.
const SETTLE: Duration = Duration::from_secs(10);

/// Made by the anchor in its fresh mount namespace: the host's own shared memory, then a
/// line to say it is ready, then a wait for the end of its stdin (the test's pipe).
const ANCHOR_SCRIPT: &str = "mount -t tmpfs lewis-shm /dev/shm \
    && mkdir -p /tmp/iceoryx2 \
    && mount -t tmpfs lewis-iceoryx2 /tmp/iceoryx2 \
    && echo ready \
    && exec cat >/dev/null";

/// Run by `nsenter` once in the host's namespaces, with the caller's working directory
/// still open: entering a mount namespace keeps that directory as it is seen from the
/// test's namespace (paths relative to it would escape the host's mounts), so the same path
/// is entered again in the host's. Bash, not sh: dash drops variables whose names are not
/// shell names (`a.b=1`) from the environment.
const ENTER_SCRIPT: &str = r#"dir=$(pwd -P) && cd -- "$dir" && exec -- "$@""#;

/// The programs this harness runs, by absolute path.
struct Tools {
    ip: PathBuf,
    unshare: PathBuf,
    nsenter: PathBuf,
    bash: PathBuf,
}

/// The tools, looked up once per process.
fn tools() -> Result<&'static Tools, Unavailable> {
    static TOOLS: OnceLock<Result<Tools, String>> = OnceLock::new();
    TOOLS
        .get_or_init(|| {
            Ok(Tools {
                ip: find("ip", "iproute2")?,
                unshare: find("unshare", "util-linux")?,
                nsenter: find("nsenter", "util-linux")?,
                bash: find("bash", "bash")?,
            })
        })
        .as_ref()
        .map_err(|why| Unavailable(why.clone()))
}

/// A program on `PATH` or in the system's directories (`ip` is in `/usr/sbin`).
fn find(program: &str, package: &str) -> Result<PathBuf, String> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .chain(["/usr/sbin", "/sbin", "/usr/bin", "/bin"].map(PathBuf::from))
        .map(|dir| dir.join(program))
        .find(|candidate| candidate.is_file())
        .ok_or_else(|| format!("`{program}` ({package}) is not installed"))
}

/// Whether a tool's complaint means the machine forbids it, rather than a fault.
fn forbidden(stderr: &str) -> bool {
    let stderr = stderr.to_lowercase();
    stderr.contains("operation not permitted") || stderr.contains("permission denied")
}

/// Runs a command to completion.
fn output(command: &mut Command) -> Output {
    command
        .stdin(Stdio::null())
        .output()
        .unwrap_or_else(|err| panic!("cannot run {command:?}: {err}"))
}

/// Runs `ip WORDS` (split at spaces), and returns its stdout.
///
/// # Panics
/// When it fails.
fn ip(tools: &Tools, words: &str) -> String {
    let mut command = Command::new(&tools.ip);
    command.args(words.split_whitespace());
    let out = output(&mut command);
    assert!(
        out.status.success(),
        "{command:?} failed ({}): {}",
        out.status,
        String::from_utf8_lossy(&out.stderr).trim()
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The processes in a network namespace (`ip netns pids`); none when it is gone.
fn netns_pids(tools: &Tools, netns: &str) -> Vec<u32> {
    let out = output(Command::new(&tools.ip).args(["netns", "pids", netns]));
    String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .filter_map(|pid| pid.parse().ok())
        .collect()
}

/// Kills every process in a network namespace and deletes it (its devices go with it).
/// Says on stderr what it could not do: it runs in `Drop`.
#[allow(clippy::print_stderr)]
fn remove_netns(tools: &Tools, netns: &str) {
    let deadline = Instant::now() + SETTLE;
    loop {
        let pids = netns_pids(tools, netns);
        if pids.is_empty() {
            break;
        }
        if Instant::now() > deadline {
            eprintln!("hosts: processes {pids:?} are left in {netns}");
            break;
        }
        for pid in pids {
            if let Ok(pid) = i32::try_from(pid) {
                // Gone already is as good as killed.
                let _ = kill(Pid::from_raw(pid), Signal::SIGKILL);
            }
        }
        // A killed process leaves the namespace when it has exited; a few milliseconds.
        std::thread::sleep(Duration::from_millis(5));
    }
    let out = output(Command::new(&tools.ip).args(["netns", "delete", netns]));
    if !out.status.success() {
        eprintln!(
            "hosts: cannot delete {netns}: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
}

/// The pid of the test process that made a namespace of this harness (`lw<pid>-...`).
fn owner(netns: &str) -> Option<u32> {
    netns.strip_prefix("lw")?.split_once('-')?.0.parse().ok()
}

/// Removes, once per test process, the namespaces that test processes killed before their
/// `Drop` left behind (`cargo test` interrupted): those of processes gone, and those named
/// after this very process, which has made none yet.
fn sweep(tools: &Tools) {
    static SWEPT: Once = Once::new();
    SWEPT.call_once(|| {
        let own = std::process::id();
        for line in ip(tools, "netns list").lines() {
            let Some(netns) = line.split_whitespace().next() else {
                continue;
            };
            if let Some(pid) = owner(netns)
                && (pid == own || !Path::new(&format!("/proc/{pid}")).exists())
            {
                remove_netns(tools, netns);
            }
        }
    });
}

/// The address of host `k` (0-based) on the segment.
fn address(k: usize) -> Ipv4Addr {
    Ipv4Addr::new(10, 0, 0, u8::try_from(k + 1).expect("at most 253 hosts"))
}

/// One host: a network namespace with its anchor process.
pub struct Host {
    name: String,
    netns: String,
    address: Ipv4Addr,
    /// Its device on the segment: `br0` on the first host, `veth0` on the others.
    device: &'static str,
    anchor: Child,
    tools: &'static Tools,
}

impl Host {
    /// Its name, as given to [`Hosts::new`].
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Its network namespace's name (`ip netns list`, `ip -n NETNS ...`).
    #[must_use]
    pub fn netns(&self) -> &str {
        &self.netns
    }

    /// Its address on the segment, at which every other host reaches it.
    #[must_use]
    pub fn address(&self) -> Ipv4Addr {
        self.address
    }

    /// The pid of its anchor, whose namespaces its programs join (`nsenter --target PID
    /// --net --ipc --mount` to look around it by hand).
    #[must_use]
    pub fn anchor_pid(&self) -> u32 {
        self.anchor.id()
    }

    /// A command running `program` in this host: in its network, IPC and mount namespaces,
    /// so with its own `/dev/shm` and `/tmp/iceoryx2`, and every other path as in the test.
    /// Add arguments, environment, working directory (default: the test's) and stdio as to
    /// any command; they reach the program. The process started is the program itself
    /// ([`Child::id`] is its pid) after `nsenter` and bash have replaced themselves with it.
    /// Bash adds `PWD`, `OLDPWD`, `SHLVL` and `_` to the environment, and says so on stderr
    /// (exit status 127) when the program cannot be found.
    ///
    /// [`Command::get_program`] is `nsenter`; the program and its arguments follow in
    /// [`Command::get_args`].
    #[must_use]
    pub fn command(&self, program: impl AsRef<OsStr>) -> Command {
        let mut command = Command::new(&self.tools.nsenter);
        command
            .arg(format!("--target={}", self.anchor_pid()))
            // `--wd=.`: the directory the command is started in (its `current_dir`),
            // entered again by path in the host (see ENTER_SCRIPT).
            .args(["--net", "--ipc", "--mount", "--wd=.", "--"])
            .arg(&self.tools.bash)
            .args(["-c", ENTER_SCRIPT])
            // Bash's $0: its name in its own complaints.
            .arg(format!("host {}", self.name))
            .arg(program);
        command
    }

    /// The processes in this host other than its anchor (`ip netns pids`): what is left
    /// running in it.
    #[must_use]
    pub fn processes(&self) -> Vec<u32> {
        let anchor = self.anchor_pid();
        netns_pids(self.tools, &self.netns)
            .into_iter()
            .filter(|&pid| pid != anchor)
            .collect()
    }
}

/// Hosts on one Ethernet segment, made by [`Hosts::new`]. Dropping it kills every process
/// left in them and deletes their namespaces, with their devices.
pub struct Hosts {
    hosts: Vec<Host>,
    /// Every namespace made so far, removed in `Drop` even when its host was not finished.
    namespaces: Vec<String>,
    tools: &'static Tools,
}

impl Hosts {
    /// Makes a host of each name (ASCII letters, digits, `-` and `_`), on one segment whose
    /// switch is in the first host (see the [module](self)), each with its anchor running.
    /// Returns once every link is up. Names of namespaces are unique per test process and
    /// call (`lw<pid>-<n>-<name>`), so tests may run in parallel.
    ///
    /// # Errors
    /// [`Unavailable`] when the machine forbids it: not root, namespaces or mounts not
    /// permitted, a tool missing.
    ///
    /// # Panics
    /// When the names are not as above, or anything else fails.
    pub fn new(names: &[&str]) -> Result<Self, Unavailable> {
        assert!(
            (1..=253).contains(&names.len()),
            "from 1 to 253 hosts, not {}",
            names.len()
        );
        for (i, name) in names.iter().enumerate() {
            assert!(
                !name.is_empty()
                    && name
                        .chars()
                        .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_'),
                "a host's name is ASCII letters, digits, `-` and `_`, not {name:?}"
            );
            assert!(!names[..i].contains(name), "two hosts named {name}");
        }
        let tools = tools()?;
        if !rustix::process::geteuid().is_root() {
            return Err(Unavailable(
                "network namespaces need root (`ip netns add`)".into(),
            ));
        }
        sweep(tools);

        static NEXT: AtomicU32 = AtomicU32::new(0);
        let prefix = format!(
            "lw{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        );
        // Dropped on any early return or panic below: what was made so far is removed.
        let mut hosts = Self {
            hosts: Vec::new(),
            namespaces: Vec::new(),
            tools,
        };
        for name in names {
            hosts.add_netns(&format!("{prefix}-{name}"))?;
        }
        hosts.wire();
        for (k, name) in names.iter().enumerate() {
            let netns = hosts.namespaces[k].clone();
            let anchor = hosts.anchor(&netns)?;
            hosts.hosts.push(Host {
                name: (*name).to_owned(),
                netns,
                address: address(k),
                device: if k == 0 { "br0" } else { "veth0" },
                anchor,
                tools,
            });
        }
        for k in 1..names.len() {
            hosts.wait_link_up(k);
        }
        Ok(hosts)
    }

    /// The host of that name.
    ///
    /// # Panics
    /// When there is none.
    #[must_use]
    pub fn host(&self, name: &str) -> &Host {
        &self.hosts[self.index(name)]
    }

    /// Cuts the cable between `a` and `b`, one of them the first host (the switch): the
    /// switch's port goes down and the other host loses its carrier, as when a cable is
    /// pulled. Nothing passes either way; a packet sent is lost, so a connection attempt
    /// times out (addresses and routes stay).
    ///
    /// # Panics
    /// When there is no such link.
    pub fn link_down(&self, a: &str, b: &str) {
        let port = self.port(a, b);
        let hub = &self.hosts[0].netns;
        ip(self.tools, &format!("-n {hub} link set {port} down"));
    }

    /// Restores the cable between `a` and `b` cut by [`Hosts::link_down`], and returns once
    /// both ends are up and the switch forwards on its port.
    ///
    /// # Panics
    /// When there is no such link, or it does not come up within seconds.
    pub fn link_up(&self, a: &str, b: &str) {
        let port = self.port(a, b);
        let hub = &self.hosts[0].netns;
        ip(self.tools, &format!("-n {hub} link set {port} up"));
        let k = port
            .strip_prefix("veth")
            .and_then(|k| k.parse().ok())
            .expect("ports are named veth<k>");
        self.wait_link_up(k);
    }

    /// The index of the host of that name.
    fn index(&self, name: &str) -> usize {
        self.hosts
            .iter()
            .position(|host| host.name == name)
            .unwrap_or_else(|| panic!("no host named {name}"))
    }

    /// The switch's port (in the first host) of the cable between `a` and `b`.
    fn port(&self, a: &str, b: &str) -> String {
        match (self.index(a), self.index(b)) {
            (0, k) | (k, 0) if k != 0 => format!("veth{k}"),
            _ => panic!(
                "no link between {a} and {b}: every host is linked to the first, {}",
                self.hosts[0].name
            ),
        }
    }

    /// Adds a network namespace, with its loopback up.
    fn add_netns(&mut self, netns: &str) -> Result<(), Unavailable> {
        // Made one at a time: the first `ip netns add` on a machine mounts /run/netns, and
        // two at once can mount it twice, one hiding the other's namespaces.
        static ADDING: Mutex<()> = Mutex::new(());
        let out = {
            let _one = ADDING
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            output(Command::new(&self.tools.ip).args(["netns", "add", netns]))
        };
        let stderr = String::from_utf8_lossy(&out.stderr);
        if !out.status.success() {
            if forbidden(&stderr) {
                return Err(Unavailable(format!(
                    "ip netns add {netns}: {}",
                    stderr.trim()
                )));
            }
            panic!(
                "ip netns add {netns} failed ({}): {}",
                out.status,
                stderr.trim()
            );
        }
        self.namespaces.push(netns.to_owned());
        ip(self.tools, &format!("-n {netns} link set lo up"));
        Ok(())
    }

    /// Builds the segment: the switch `br0` in the first host, a cable from its port
    /// `veth<k>` to `veth0` in host `k`, the addresses, the multicast routes.
    fn wire(&self) {
        let hub = &self.namespaces[0];
        let tools = self.tools;
        // Multicast snooping off: with no querier on the segment, a snooping switch stops
        // forwarding a group once its members' reports expire.
        ip(
            tools,
            &format!("-n {hub} link add br0 type bridge mcast_snooping 0"),
        );
        ip(
            tools,
            &format!("-n {hub} address add {}/24 dev br0", address(0)),
        );
        ip(tools, &format!("-n {hub} link set br0 up"));
        ip(tools, &format!("-n {hub} route add 224.0.0.0/4 dev br0"));
        for (k, netns) in self.namespaces.iter().enumerate().skip(1) {
            // Made in the namespaces directly: the names need only be unique in each.
            ip(
                tools,
                &format!("link add veth{k} netns {hub} type veth peer name veth0 netns {netns}"),
            );
            ip(tools, &format!("-n {hub} link set veth{k} master br0 up"));
            let address = Ipv4Addr::new(10, 0, 0, u8::try_from(k + 1).expect("at most 253"));
            ip(
                tools,
                &format!("-n {netns} address add {address}/24 dev veth0"),
            );
            ip(tools, &format!("-n {netns} link set veth0 up"));
            ip(
                tools,
                &format!("-n {netns} route add 224.0.0.0/4 dev veth0"),
            );
        }
    }

    /// Starts a host's anchor in its network namespace, and waits until it has made the
    /// host's shared memory.
    fn anchor(&self, netns: &str) -> Result<Child, Unavailable> {
        let mut command = Command::new(&self.tools.ip);
        command
            .args(["netns", "exec", netns])
            .arg(&self.tools.unshare)
            .args(["--ipc", "--mount", "--propagation", "private"])
            .args(["/bin/sh", "-c", ANCHOR_SCRIPT])
            .current_dir("/")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        let mut anchor = command
            .spawn()
            .unwrap_or_else(|err| panic!("cannot start {command:?}: {err}"));
        let mut line = String::new();
        // It writes its line or exits, closing the pipe: this read ends either way.
        if let Some(out) = anchor.stdout.take() {
            let _ = BufReader::new(out).read_line(&mut line);
        }
        if line.trim() == "ready" {
            // Its stderr is not read again.
            anchor.stderr = None;
            return Ok(anchor);
        }
        let _ = anchor.kill();
        let status = anchor.wait();
        let mut stderr = String::new();
        if let Some(mut err) = anchor.stderr.take() {
            let _ = err.read_to_string(&mut stderr);
        }
        if forbidden(&stderr) {
            return Err(Unavailable(format!(
                "cannot make a host's IPC and mount namespaces: {}",
                stderr.trim()
            )));
        }
        panic!(
            "the anchor of {netns} did not start ({status:?}): {}",
            stderr.trim()
        );
    }

    /// Waits until both ends of the cable to host `k` are up and the switch forwards on
    /// its port: a packet sent before would be lost.
    fn wait_link_up(&self, k: usize) {
        let port = format!("veth{k}");
        let ends = [
            (self.hosts[0].netns.as_str(), port.as_str()),
            (self.hosts[k].netns.as_str(), self.hosts[k].device),
        ];
        let deadline = Instant::now() + SETTLE;
        loop {
            let states = ends
                .map(|(netns, dev)| ip(self.tools, &format!("-n {netns} -d -o link show {dev}")));
            let up = states.iter().all(|state| state.contains(" state UP "))
                && states[0].contains("bridge_slave state forwarding");
            if up {
                return;
            }
            assert!(
                Instant::now() < deadline,
                "the link to {} does not come up:\n{}",
                self.hosts[k].name,
                states.join("")
            );
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

impl Drop for Hosts {
    fn drop(&mut self) {
        for host in &mut self.hosts {
            let _ = host.anchor.kill();
            let _ = host.anchor.wait();
        }
        for netns in &self.namespaces {
            remove_netns(self.tools, netns);
        }
    }
}
