//! A server's TLS identity from a PEM certificate and key on disk.

use std::path::{Path, PathBuf};

use tonic::transport::{Identity, Server, ServerTlsConfig};

/// Why a server cannot serve TLS.
#[derive(Debug, thiserror::Error)]
pub enum TlsError {
    /// The certificate or key file cannot be read.
    #[error("cannot read the TLS {what} {}", path.display())]
    File {
        /// "certificate" or "key".
        what: &'static str,
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The certificate and key do not form a usable identity.
    #[error("cannot serve TLS with that certificate and key")]
    Config(#[source] tonic::transport::Error),
}

/// `builder` serving TLS with the PEM certificate and key `tls` names, or
/// `builder` unchanged (plain HTTP/2) when `tls` is `None`.
pub fn with_tls(builder: Server, tls: Option<&(PathBuf, PathBuf)>) -> Result<Server, TlsError> {
    let Some((cert, key)) = tls else {
        return Ok(builder);
    };
    let read = |what, path: &Path| {
        std::fs::read(path).map_err(|source| TlsError::File {
            what,
            path: path.to_path_buf(),
            source,
        })
    };
    let identity = Identity::from_pem(read("certificate", cert)?, read("key", key)?);
    builder
        .tls_config(ServerTlsConfig::new().identity(identity))
        .map_err(TlsError::Config)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_tls_leaves_the_builder_as_it_is() {
        assert!(with_tls(Server::builder(), None).is_ok());
    }

    #[test]
    fn a_missing_file_is_named_with_its_role() {
        let dir = std::env::temp_dir().join(format!("buridan-tls-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let cert = dir.join("cert.pem");
        std::fs::write(&cert, "not a certificate").unwrap();
        let key = dir.join("missing-key.pem");
        let err = with_tls(Server::builder(), Some(&(cert, key.clone()))).unwrap_err();
        match &err {
            TlsError::File { what, path, .. } => {
                assert_eq!(*what, "key");
                assert_eq!(path, &key);
            }
            other => panic!("expected a file error, got {other:?}"),
        }
        assert!(err.to_string().contains("missing-key.pem"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
