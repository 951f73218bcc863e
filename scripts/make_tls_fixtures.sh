#!/usr/bin/env bash
# Writes the test-only certificate authority and server certificate that the Zarr-over-https
# tests serve from 127.0.0.1 (crates/isogrid-io/tests/fixtures/tls/): a CA, and a certificate for
# 127.0.0.1 and localhost signed by it, both valid for 100 years. The keys are public test
# fixtures and protect nothing. Needs openssl.
set -euo pipefail
out="$(cd "$(dirname "$0")/.." && pwd)/crates/isogrid-io/tests/fixtures/tls"
mkdir -p "$out"
cd "$out"
openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days 36500 \
  -subj "/CN=isogrid test CA" -keyout ca.key -out ca.pem \
  -addext basicConstraints=critical,CA:TRUE -addext keyUsage=critical,keyCertSign,cRLSign
openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -subj "/CN=127.0.0.1" \
  -keyout server.key -out server.csr
openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -days 36500 \
  -out server.pem -extfile <(printf '%s\n' \
    "subjectAltName=IP:127.0.0.1,DNS:localhost" \
    "basicConstraints=critical,CA:FALSE" \
    "keyUsage=critical,digitalSignature" \
    "extendedKeyUsage=serverAuth")
# The server key as PKCS#8, which rustls reads without extra parsers.
openssl pkcs8 -topk8 -nocrypt -in server.key -out server.key.pk8 && mv server.key.pk8 server.key
rm -f server.csr ca.key ca.srl
