//! A read-only `zarrs` store over HTTP, for Zarr and OME-Zarr served as static files (public
//! OME-Zarr collections are served this way): every store key is a URL under the store's base URL.
//!
//! Built on `ureq`, which is small and blocking. `https://` comes with the `https` feature (on by
//! default): rustls, trusting Mozilla's root certificates, or the certificates of a PEM file
//! ([`crate::ZarrOptions::trusted_certificates`], which the CLI and Python take from
//! `SSL_CERT_FILE`) for a site's own certificate authority or a TLS-intercepting proxy. The `zarrs_http` crate does the same through `reqwest`, which would bring an async
//! runtime into every build. Byte ranges (shard indexes and inner
//! chunks) are asked for with `Range` headers; a server that ignores them and answers 200 with the
//! whole object is served by slicing, so simple static servers work too. A 404 is a missing key
//! (a missing chunk reads as the fill value, as the Zarr specs say); any other failure is an
//! error naming the URL.

use std::time::Duration;
use zarrs::storage::byte_range::{ByteRange, ByteRangeIterator};
use zarrs::storage::{
    Bytes, MaybeBytes, MaybeBytesIterator, ReadableStorageTraits, StorageError, StoreKey,
};

/// The deadline in seconds the environment variable `name` gives (`default` when unset): how long
/// a connection may take (`ISOGRID_HTTP_CONNECT_TIMEOUT`, 30 s), and how long a server may keep
/// an answer or the next bytes of one waiting (`ISOGRID_HTTP_TIMEOUT`, 120 s).
fn seconds_from_env(name: &str, default: f64) -> isogrid::Result<Duration> {
    let seconds = match std::env::var(name) {
        Ok(text) => text
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|s| s.is_finite() && *s > 0.0 && *s < 1e9)
            .ok_or_else(|| {
                isogrid::Error::invalid(format!("{name}={text}: not a positive number of seconds"))
            })?,
        Err(_) => default,
    };
    Ok(Duration::from_secs_f64(seconds))
}

/// A Zarr store rooted at an HTTP(S) URL.
pub struct HttpStore {
    agent: ureq::Agent,
    base: String,
}

impl HttpStore {
    /// A store whose keys are resolved under `base_url` (with or without a trailing slash);
    /// `https://` servers must prove themselves to `trusted` (a PEM file of root certificates) or,
    /// when it is `None`, to Mozilla's roots. Fails only when an `https://` store's `trusted` cannot be
    /// read or holds no certificate.
    pub fn new(base_url: &str, trusted: Option<&std::path::Path>) -> isogrid::Result<Self> {
        let connect = seconds_from_env("ISOGRID_HTTP_CONNECT_TIMEOUT", 30.0)?;
        let answer = seconds_from_env("ISOGRID_HTTP_TIMEOUT", 120.0)?;
        let config = ureq::Agent::config_builder()
            // Statuses are answers to interpret (404 = missing key), not transport errors.
            .http_status_as_error(false)
            .timeout_connect(Some(connect))
            .timeout_recv_response(Some(answer))
            .timeout_per_read(Some(answer));
        // Only https:// reads the trusted certificates: a bad SSL_CERT_FILE must not stop a
        // plain http:// store.
        let is_https = base_url
            .get(..8)
            .is_some_and(|s| s.eq_ignore_ascii_case("https://"));
        #[cfg(feature = "https")]
        let config = if is_https {
            config.tls_config(tls::config(trusted)?)
        } else {
            config
        };
        #[cfg(not(feature = "https"))]
        let _ = (trusted, is_https);
        Ok(HttpStore {
            agent: ureq::Agent::new_with_config(config.build()),
            base: base_url.trim_end_matches('/').to_string(),
        })
    }

    fn url(&self, key: &StoreKey) -> String {
        format!("{}/{}", self.base, key.as_str())
    }

    /// GETs `url`, with `range` as a `Range` header value when given. `None` on 404; otherwise the
    /// status (200 or 206) and the body.
    fn fetch(&self, url: &str, range: Option<&str>) -> Result<Option<(u16, Bytes)>, StorageError> {
        let mut request = self.agent.get(url);
        if let Some(range) = range {
            request = request.header("Range", range);
        }
        let response = request
            .call()
            .map_err(|e| StorageError::from(format!("{url}: {e}")))?;
        let status = response.status().as_u16();
        match status {
            404 => Ok(None),
            200 | 206 => {
                let body = response
                    .into_body()
                    .with_config()
                    .limit(u64::MAX)
                    .read_to_vec()
                    .map_err(|e| StorageError::from(format!("{url}: {e}")))?;
                Ok(Some((status, Bytes::from(body))))
            }
            _ => Err(StorageError::from(format!("{url}: HTTP status {status}"))),
        }
    }

    /// One byte range of the object at `url`; `None` when the server has no such object.
    fn fetch_range(&self, url: &str, range: ByteRange) -> Result<MaybeBytes, StorageError> {
        let header = match range {
            ByteRange::FromStart(0, None) => None,
            ByteRange::FromStart(_, Some(0)) => return Ok(Some(Bytes::new())),
            ByteRange::FromStart(start, None) => Some(format!("bytes={start}-")),
            ByteRange::FromStart(start, Some(len)) => {
                // The range comes from a shard index, i.e. from the data: it may overflow.
                let last = start.checked_add(len - 1).ok_or_else(|| {
                    StorageError::from(format!("{url}: byte range {start}+{len} overflows"))
                })?;
                Some(format!("bytes={start}-{last}"))
            }
            ByteRange::Suffix(0) => return Ok(Some(Bytes::new())),
            ByteRange::Suffix(len) => Some(format!("bytes=-{len}")),
        };
        let Some((status, body)) = self.fetch(url, header.as_deref())? else {
            return Ok(None);
        };
        if status == 206 || header.is_none() {
            let expected = match range {
                ByteRange::FromStart(_, Some(len)) | ByteRange::Suffix(len) => Some(len),
                ByteRange::FromStart(_, None) => None,
            };
            if expected.is_some_and(|len| body.len() as u64 != len) {
                return Err(StorageError::from(format!(
                    "{url}: asked for {} bytes ({}), got {}",
                    expected.unwrap_or(0),
                    header.unwrap_or_default(),
                    body.len()
                )));
            }
            return Ok(Some(body));
        }
        // 200 to a range request: the server sent the whole object.
        let size = body.len() as u64;
        // Checked: a suffix longer than the object (a shard shorter than its index) or an end
        // past u64 is the data's fault, not a reason to panic.
        let (start, end) = match range {
            ByteRange::FromStart(start, None) => (Some(start), Some(size)),
            ByteRange::FromStart(start, Some(len)) => (Some(start), start.checked_add(len)),
            ByteRange::Suffix(len) => (size.checked_sub(len), Some(size)),
        };
        let (start, end) = (start.unwrap_or(u64::MAX), end.unwrap_or(u64::MAX));
        if start > end || end > size {
            return Err(StorageError::from(format!(
                "{url}: bytes {start}..{end} asked for, but the object has {size}"
            )));
        }
        Ok(Some(body.slice(start as usize..end as usize)))
    }
}

impl ReadableStorageTraits for HttpStore {
    fn get(&self, key: &StoreKey) -> Result<MaybeBytes, StorageError> {
        Ok(self.fetch(&self.url(key), None)?.map(|(_, body)| body))
    }

    fn get_partial_many<'a>(
        &'a self,
        key: &StoreKey,
        byte_ranges: ByteRangeIterator<'a>,
    ) -> Result<MaybeBytesIterator<'a>, StorageError> {
        let url = self.url(key);
        let mut parts = Vec::new();
        for range in byte_ranges {
            match self.fetch_range(&url, range)? {
                Some(bytes) => parts.push(Ok(bytes)),
                None => return Ok(None),
            }
        }
        Ok(Some(Box::new(parts.into_iter())))
    }

    fn size_key(&self, key: &StoreKey) -> Result<Option<u64>, StorageError> {
        let url = self.url(key);
        let response = self
            .agent
            .head(&url)
            .call()
            .map_err(|e| StorageError::from(format!("{url}: {e}")))?;
        match response.status().as_u16() {
            404 => Ok(None),
            200 => response
                .headers()
                .get("content-length")
                .and_then(|v| v.to_str().ok())
                .and_then(|v| v.parse().ok())
                .map(Some)
                .ok_or_else(|| StorageError::from(format!("{url}: no Content-Length"))),
            status => Err(StorageError::from(format!("{url}: HTTP status {status}"))),
        }
    }

    fn supports_get_partial(&self) -> bool {
        true
    }
}

/// The TLS settings of the store's agent: which certificates it trusts.
#[cfg(feature = "https")]
mod tls {
    use isogrid::{Error, Result};
    use std::path::Path;
    use std::sync::Arc;
    use ureq::tls::{parse_pem, PemItem, RootCerts, TlsConfig};

    pub(super) fn config(trusted: Option<&Path>) -> Result<TlsConfig> {
        let roots = match trusted {
            Some(path) => roots_from(path)?,
            None => RootCerts::WebPki,
        };
        Ok(TlsConfig::builder().root_certs(roots).build())
    }

    /// The certificates of a PEM file; other PEM items (keys) are skipped.
    fn roots_from(path: &Path) -> Result<RootCerts> {
        let named = |problem: String| {
            Error::invalid(format!("trusted certificates (SSL_CERT_FILE): {problem}"))
                .with_path(path)
        };
        let pem = std::fs::read(path).map_err(|e| named(format!("it cannot be read: {e}")))?;
        let mut certs = Vec::new();
        for item in parse_pem(&pem) {
            match item {
                Ok(PemItem::Certificate(cert)) => certs.push(cert),
                Ok(_) => {}
                Err(e) => return Err(named(format!("it is not valid PEM: {e}"))),
            }
        }
        if certs.is_empty() {
            return Err(named("it holds no certificate".into()));
        }
        Ok(RootCerts::Specific(Arc::new(certs)))
    }
}
