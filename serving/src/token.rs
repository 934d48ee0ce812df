//! The bearer-token check every server applies when it is given a token.

use tonic::service::Interceptor;
use tonic::{Request, Status};

/// An interceptor that lets a call through only with `authorization:
/// Bearer TOKEN`, or every call when no token is set.
///
/// ```
/// use buridan_serving::BearerToken;
/// use tonic::service::Interceptor;
/// let mut check = BearerToken::new(Some("s3cret"), "this service needs a token");
/// let mut req = tonic::Request::new(());
/// req.metadata_mut().insert("authorization", "Bearer s3cret".parse().unwrap());
/// assert!(check.call(req).is_ok());
/// let refused = check.call(tonic::Request::new(())).unwrap_err();
/// assert_eq!(refused.code(), tonic::Code::Unauthenticated);
/// assert_eq!(refused.message(), "this service needs a token");
/// ```
#[derive(Clone)]
pub struct BearerToken {
    /// `Bearer TOKEN`, as the header must read.
    expected: Option<String>,
    /// The refusal of a call without the header: how to send the token.
    missing: &'static str,
    /// Called with each refusal (a metric, a log line).
    on_refusal: fn(&Status),
}

impl BearerToken {
    /// Checks for `token` (none: every call passes). A call without the
    /// header is refused with `missing`, one with another token with
    /// "wrong token".
    pub fn new(token: Option<&str>, missing: &'static str) -> Self {
        Self {
            expected: token.map(|t| format!("Bearer {t}")),
            missing,
            on_refusal: |_| {},
        }
    }

    /// The same check, calling `f` with each refusal before it is sent.
    pub fn on_refusal(self, f: fn(&Status)) -> Self {
        Self {
            on_refusal: f,
            ..self
        }
    }
}

impl Interceptor for BearerToken {
    fn call(&mut self, req: Request<()>) -> Result<Request<()>, Status> {
        let Some(expected) = &self.expected else {
            return Ok(req);
        };
        let status = match req.metadata().get("authorization") {
            Some(v) if v.as_bytes() == expected.as_bytes() => return Ok(req),
            Some(_) => Status::unauthenticated("wrong token"),
            None => Status::unauthenticated(self.missing),
        };
        (self.on_refusal)(&status);
        Err(status)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    fn with_header(value: &str) -> Request<()> {
        let mut req = Request::new(());
        req.metadata_mut()
            .insert("authorization", value.parse().unwrap());
        req
    }

    #[test]
    fn without_a_token_every_call_passes() {
        let mut check = BearerToken::new(None, "unused");
        assert!(check.call(Request::new(())).is_ok());
        assert!(check.call(with_header("Bearer anything")).is_ok());
    }

    #[test]
    fn a_wrong_token_and_a_missing_one_are_refused_apart() {
        static REFUSED: AtomicUsize = AtomicUsize::new(0);
        let mut check = BearerToken::new(Some("t"), "send a token").on_refusal(|_| {
            REFUSED.fetch_add(1, Ordering::SeqCst);
        });
        assert!(check.call(with_header("Bearer t")).is_ok());
        let wrong = check.call(with_header("Bearer u")).unwrap_err();
        assert_eq!(wrong.message(), "wrong token");
        let bare = check.call(with_header("t")).unwrap_err();
        assert_eq!(bare.message(), "wrong token");
        let missing = check.call(Request::new(())).unwrap_err();
        assert_eq!(missing.code(), tonic::Code::Unauthenticated);
        assert_eq!(missing.message(), "send a token");
        assert_eq!(REFUSED.load(Ordering::SeqCst), 3);
    }
}
