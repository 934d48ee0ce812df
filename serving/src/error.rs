//! What can go wrong in any server, whatever it serves.

use std::net::SocketAddr;

use crate::TlsError;

/// Why a server could not start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    /// The async runtime (or the server's thread) could not start.
    #[error("cannot start the server's runtime")]
    Runtime(#[source] std::io::Error),
    /// The address cannot be listened on.
    #[error("cannot listen on {addr}")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// The OS error.
        source: std::io::Error,
    },
    /// The TLS certificate or key cannot be read or used.
    #[error(transparent)]
    Tls(#[from] TlsError),
    /// The gRPC server failed.
    #[error("the gRPC server failed")]
    Transport(#[source] tonic::transport::Error),
}

/// A listener bound to `addr` (port 0: any free port), non-blocking, and
/// the address it got.
///
/// It is bound with std so that a caller inside a runtime of its own (an
/// async test) may bind it too; `tokio::net::TcpListener::from_std`
/// registers it with the runtime that serves it.
pub fn bind(addr: SocketAddr) -> Result<(std::net::TcpListener, SocketAddr), ServerError> {
    let failed = |source| ServerError::Bind { addr, source };
    let listener = std::net::TcpListener::bind(addr).map_err(failed)?;
    listener.set_nonblocking(true).map_err(failed)?;
    let bound = listener.local_addr().map_err(failed)?;
    Ok((listener, bound))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_taken_address_is_named() {
        let (_held, bound) = bind("127.0.0.1:0".parse().unwrap()).unwrap();
        let err = bind(bound).unwrap_err();
        assert!(matches!(err, ServerError::Bind { addr, .. } if addr == bound));
        assert_eq!(err.to_string(), format!("cannot listen on {bound}"));
    }
}
