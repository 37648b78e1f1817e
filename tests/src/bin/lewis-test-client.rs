//! A client application in a process of its own, for tests that kill a client: it asks the
//! broker of `LEWIS_NAMESPACE` for RangeFinder as client `NAME` (the first argument), prints
//! `bound to PROVIDER` once bound, then receives samples until it is killed.

use std::io::Write as _;
use std::rc::Rc;
use std::time::Duration;

use lewis_interfaces::msg::RangeFinder;
use lewis_runtime::client::Client;
use lewis_runtime::ipc::Ipc;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let name = std::env::args()
        .nth(1)
        .ok_or("usage: lewis-test-client NAME")?;
    let ipc = Rc::new(Ipc::open_from_env(&name)?);
    let mut client = Client::<RangeFinder>::connect(&ipc, &name)?;
    let provider = client.wait_bound(Duration::from_secs(30))?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "bound to {provider}")?;
    out.flush()?;
    loop {
        client.recv_timeout(Duration::from_secs(1))?;
    }
}
