// A static server for the browser tests until they run against `isogrid serve`: web/dist at /, and
// named files (name → bytes) beside it, with Range support through the `send` package or, with
// `ranges: false`, a server that ignores Range (always 200, whole file). It logs each request's
// byte range per path; `delayMs` holds each range response back, like a slow network;
// `pageHeaders` go with the page and its bundle (a Content-Security-Policy, say).
import http from 'node:http';
import send from 'send';
import { join } from 'node:path';

export async function startServer({ dist, files, ranges = true, delayMs = 0, pageHeaders = {} }) {
  const log = [];
  const server = http.createServer(async (req, res) => {
    const path = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    const name = path.slice(1);
    if (files[name]) {
      const bytes = files[name];
      const m = /^bytes=(\d+)-(\d+)$/.exec(req.headers.range || '');
      if (ranges && m) {
        const start = Number(m[1]);
        const end = Math.min(Number(m[2]) + 1, bytes.length);
        if (start >= bytes.length || start >= end) {
          res.writeHead(416, { 'Content-Range': `bytes */${bytes.length}` }).end();
          return;
        }
        log.push({ path, start, end });
        if (delayMs) await new Promise((r) => setTimeout(r, delayMs));
        res.writeHead(206, {
          'Content-Type': 'application/octet-stream',
          'Content-Range': `bytes ${start}-${end - 1}/${bytes.length}`,
          'Content-Length': end - start,
          'Accept-Ranges': 'bytes',
        });
        res.end(bytes.subarray(start, end));
      } else {
        log.push({ path, start: 0, end: bytes.length });
        res.writeHead(200, { 'Content-Type': 'application/octet-stream', 'Content-Length': bytes.length });
        res.end(bytes);
      }
      return;
    }
    for (const [k, v] of Object.entries(pageHeaders)) res.setHeader(k, v);
    send(req, path === '/' ? '/index.html' : path, { root: dist }).pipe(res);
  });
  await new Promise((r) => server.listen(0, '127.0.0.1', r));
  return { url: `http://127.0.0.1:${server.address().port}`, log, close: () => new Promise((r) => server.close(r)) };
}
