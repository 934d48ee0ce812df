//! What the soak's processes share: free loopback ports, log files, and
//! SIGKILL with the reaping after it.

use std::net::{SocketAddr, TcpListener};
use std::path::Path;
use std::process::{Child, Stdio};

use crate::SoakError;

/// A loopback port free right now.
pub(crate) fn free_port() -> std::io::Result<u16> {
    Ok(TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

/// A loopback address on a port free right now.
pub(crate) fn free_loopback_addr() -> Result<SocketAddr, SoakError> {
    let port = free_port().map_err(SoakError::io("finding a free loopback port"))?;
    Ok(SocketAddr::from(([127, 0, 0, 1], port)))
}

/// Stdout and stderr of a process, both appended to `out/name`.
pub(crate) fn log_file(out: &Path, name: &str) -> Result<(Stdio, Stdio), SoakError> {
    let f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(out.join(name))
        .map_err(SoakError::io(format!("opening {name}")))?;
    let copy = f
        .try_clone()
        .map_err(SoakError::io(format!("opening {name}")))?;
    Ok((copy.into(), f.into()))
}

/// SIGKILL, then wait so no zombie is left.
pub(crate) fn kill_and_reap(child: &mut Child) {
    let _ = child.kill();
    let _ = child.wait();
}
