// docs/benchmarks-web.md's glTF side: each .glb given (bench/gltf.mjs writes them) is served on
// 127.0.0.1 beside bench/mesh.html, a plain WebGPU mesh viewer, and loaded in headless Chromium
// with the download throttled by the DevTools protocol as bench.mjs throttles the .cgc (50 Mbit/s,
// 1 Gbit/s, cache disabled): time to the last byte and to the complete picture (drawn and read
// back) from navigation start, bytes transferred, and the median of 3 more frames.
// Usage: node bench/mesh.mjs SIZE MESH.glb...
import http from 'node:http';
import send from 'send';
import { basename, dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';
import { loadavg } from 'node:os';
import puppeteer from 'puppeteer-core';

const [size, ...files] = process.argv.slice(2);
const here = dirname(fileURLToPath(import.meta.url));
const byName = Object.fromEntries(files.map((f) => [basename(f), f]));
const server = http.createServer((req, res) => {
  const path = decodeURIComponent(new URL(req.url, 'http://x').pathname).slice(1);
  if (path === 'mesh.html') return send(req, 'mesh.html', { root: here }).pipe(res);
  if (byName[path]) return send(req, basename(byName[path]), { root: dirname(byName[path]) }).pipe(res);
  res.writeHead(404).end();
});
await new Promise((r) => server.listen(0, '127.0.0.1', r));
const base = `http://127.0.0.1:${server.address().port}`;
const browser = await puppeteer.launch({
  executablePath: '/usr/bin/chromium', browser: 'chrome', headless: true, protocolTimeout: 600_000,
  args: ['--enable-unsafe-webgpu', '--no-sandbox', '--headless=new'],
});
// The machine is shared: the load average goes with the figures.
console.log(JSON.stringify({ loadAverage: loadavg() }));
try {
  for (const file of files) {
    for (const mbit of [50, 1000]) {
      const page = await browser.newPage();
      const cdp = await page.createCDPSession();
      await cdp.send('Network.enable');
      await cdp.send('Network.setCacheDisabled', { cacheDisabled: true });
      let transferred = 0;
      const ids = new Set();
      cdp.on('Network.requestWillBeSent', (e) => e.request.url.endsWith('.glb') && ids.add(e.requestId));
      cdp.on('Network.loadingFinished', (e) => ids.has(e.requestId) && (transferred += e.encodedDataLength));
      await cdp.send('Network.emulateNetworkConditions', { offline: false, latency: 1, downloadThroughput: (mbit * 1e6) / 8, uploadThroughput: (mbit * 1e6) / 8 });
      await page.goto(`${base}/mesh.html?src=/${basename(file)}&size=${size}`);
      await page.waitForFunction(() => window.done, { timeout: 0, polling: 500 });
      const d = await page.evaluate(() => window.done);
      if (d.error) throw new Error(`${file}: ${d.error}`);
      console.log(JSON.stringify({ file, mbit, size, lastByteMs: d.arrivedAt, completeMs: d.completeAt, compiledMs: d.compiledAt, transferred, triangles: d.triangles, hits: d.hits, frameMs: d.frameMs }));
      await page.close();
    }
  }
} finally {
  await browser.close();
  server.close();
}
console.log(JSON.stringify({ loadAverage: loadavg() }));
