//! TLS for `haptex serve --tls-cert FILE --tls-key FILE` (rustls, with
//! ring's cryptography): the certificate chain and the private key read
//! from PEM files, checked to belong together before the server listens.
//! Under TLS the session cookie is `Secure`, the Origin check expects
//! `https://`, and every answer carries `Strict-Transport-Security`
//! ([`add_hsts`]).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use axum::http::{HeaderName, HeaderValue};
use axum::response::Response;
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};

/// The TLS side of accepted connections.
pub type Acceptor = tokio_rustls::TlsAcceptor;

/// `Strict-Transport-Security` under TLS: a year, this host only.
pub const HSTS: &str = "max-age=31536000";

/// A certificate and key that cannot be served.
#[derive(Debug, thiserror::Error)]
pub enum TlsError {
    #[error("--tls-cert {}: {message}", path.display())]
    Certificate { path: PathBuf, message: String },
    #[error("--tls-key {}: {message}", path.display())]
    Key { path: PathBuf, message: String },
    #[error("--tls-cert {} and --tls-key {}: {message}", cert.display(), key.display())]
    Pair { cert: PathBuf, key: PathBuf, message: String },
}

/// The acceptor of the PEM certificate chain in `cert` (the server's
/// certificate first) and the PEM private key in `key` (PKCS#8, PKCS#1 or
/// SEC1), or what is wrong with them: a file that cannot be read, holds no
/// certificate or key, or a key that is not the certificate's.
pub fn acceptor(cert: &Path, key: &Path) -> Result<Acceptor, TlsError> {
    let cert_error = |message: String| TlsError::Certificate { path: cert.to_path_buf(), message };
    let key_error = |message: String| TlsError::Key { path: key.to_path_buf(), message };
    let read = |path: &Path| std::fs::read(path).map_err(|e| e.to_string());
    let cert_pem = read(cert).map_err(cert_error)?;
    let key_pem = read(key).map_err(key_error)?;
    let chain = CertificateDer::pem_slice_iter(&cert_pem)
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| cert_error(format!("not a PEM certificate chain: {e}")))?;
    if chain.is_empty() {
        return Err(cert_error("no certificate in it (a PEM block 'BEGIN CERTIFICATE')".to_string()));
    }
    let private = PrivateKeyDer::from_pem_slice(&key_pem).map_err(|e| {
        key_error(format!(
            "no private key in it (a PEM block 'BEGIN PRIVATE KEY', 'RSA PRIVATE KEY' or 'EC PRIVATE KEY'): {e}"
        ))
    })?;
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let config = rustls::ServerConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .map_err(|e| cert_error(e.to_string()))?
        .with_no_client_auth()
        .with_single_cert(chain, private)
        .map_err(|e| TlsError::Pair {
            cert: cert.to_path_buf(),
            key: key.to_path_buf(),
            message: format!("the key cannot serve the certificate: {e}"),
        })?;
    Ok(tokio_rustls::TlsAcceptor::from(Arc::new(config)))
}

/// Middleware: `Strict-Transport-Security` on every answer of a server
/// that speaks TLS.
pub async fn add_hsts(mut response: Response) -> Response {
    response.headers_mut().insert(HeaderName::from_static("strict-transport-security"), HeaderValue::from_static(HSTS));
    response
}
