// docs/benchmarks-web.md's measurements: for each .cgc given, served by `isogrid serve` on
// 127.0.0.1, the time to the first frame and to the complete picture in headless Chromium with the
// download throttled by the DevTools protocol (50 Mbit/s, 1 Gbit/s), read by ranges and, where the
// file has one, as its packed form (.cgcz, the URL `isogrid serve` prints), the bytes transferred
// and the bytes before the first frame (and each frame drawn while loading: start, duration, bytes
// in); FORMS (default 'ranges,packed') picks the forms;
// then the frame time in Chromium and Firefox at the given size (medians of FRAMES: wall time with
// the read-back, JS time to encode, GPU timestamps of the frame and of each pass, cells listed),
// for the view drawn again (visibility buffer converged) and for first frames of a view (every
// cluster visible, as after a camera move).
// Usage: node bench/bench.mjs SIZE FILE.cgc...   (e.g. 640x480; the isogrid binary as in the tests)
//   CAP_S (default 1200): seconds a throttled load may take to its complete picture; past it the
//   figures so far are printed with completeMs null. FRAMES (default 5): frames timed per browser.
//   BROWSERS (default 'chromium,firefox'; empty: none): the browsers of the frame-time part; THROTTLED=0 skips
//   the throttled loads. MAX_RSS_GB (default 8): a browser whose processes hold more memory is
//   closed and the figure reported as over the cap (SwiftShader's memory grows with the cells drawn;
//   this machine is shared). VIEWER_FROM=DIR: the page's bundle (/viewer.js) comes from DIR (e.g.
//   web/dist after `npm run build`) instead of the one built into the binary, through a proxy on
//   127.0.0.1 that passes every other request (the page, the .cgc's ranges) to `isogrid serve`
//   unchanged: a viewer change is measured without rebuilding the binary.
import { execSync, spawn } from 'node:child_process';
import http from 'node:http';
import { readFileSync, statSync } from 'node:fs';
import { createInterface } from 'node:readline';
import { loadavg } from 'node:os';
import puppeteer from 'puppeteer-core';
import { isogridBinary } from '../test/fixtures.mjs';

const [size, ...files] = process.argv.slice(2);
const capMs = 1000 * Number(process.env.CAP_S || 1200);
const frames = Number(process.env.FRAMES || 5);
const browsers = (process.env.BROWSERS ?? 'chromium,firefox').split(',').filter(Boolean);
const maxRss = Number(process.env.MAX_RSS_GB || 8) * 2 ** 30;

/** Resident bytes of `browser`'s processes (the browser and its descendants). */
function browserRss(browser) {
  const table = execSync('ps -e -o pid=,ppid=,rss=').toString().trim().split('\n').map((l) => l.trim().split(/\s+/).map(Number));
  const ids = new Set([browser.process().pid]);
  for (let grew = true; grew; ) {
    grew = false;
    for (const [pid, ppid] of table) if (ids.has(ppid) && !ids.has(pid)) (ids.add(pid), (grew = true));
  }
  return table.filter(([pid]) => ids.has(pid)).reduce((sum, [, , rss]) => sum + rss * 1024, 0);
}

/** Waits for the complete picture (or an error) for at most `ms`; false when the memory cap is hit. */
async function waitReady(browser, page, ms) {
  const until = Date.now() + ms;
  for (;;) {
    if (browserRss(browser) > maxRss) return false;
    const done = await page.evaluate(() => Boolean(window.isogrid.stats.readyAt || window.isogrid.stats.error));
    if (done || Date.now() > until) return true;
    await new Promise((r) => setTimeout(r, 2000));
  }
}

async function serve(file) {
  const child = spawn(isogridBinary(), ['serve', file, '--port', '0'], { stdio: ['ignore', 'pipe', 'inherit'] });
  const line = await new Promise((r) => createInterface({ input: child.stdout }).once('line', r));
  const url = line.split(/\s+/).find((w) => w.startsWith('http://'));
  if (!process.env.VIEWER_FROM) return { child, url };
  const upstream = new URL(url);
  const bundle = readFileSync(`${process.env.VIEWER_FROM}/viewer.js`);
  const proxy = http.createServer((req, res) => {
    if (new URL(req.url, 'http://x').pathname === '/viewer.js') {
      res.writeHead(200, { 'Content-Type': 'text/javascript', 'Content-Length': bundle.length }).end(bundle);
      return;
    }
    const up = http.request({ host: upstream.hostname, port: upstream.port, path: req.url, method: req.method, headers: req.headers }, (r) => {
      res.writeHead(r.statusCode, r.headers);
      r.pipe(res);
    });
    up.on('error', () => res.destroy());
    req.pipe(up);
  });
  await new Promise((r) => proxy.listen(0, '127.0.0.1', r));
  child.on('exit', () => proxy.close());
  return { child, url: url.replace(upstream.host, `127.0.0.1:${proxy.address().port}`) };
}

const launch = {
  chromium: { executablePath: '/usr/bin/chromium', browser: 'chrome', args: ['--enable-unsafe-webgpu', '--no-sandbox', '--headless=new'] },
  firefox: { executablePath: '/usr/bin/firefox-esr', browser: 'firefox', extraPrefsFirefox: { 'dom.webgpu.enabled': true, 'gfx.webgpu.ignore-blocklist': true } },
};

// The machine is shared: the load average goes with the figures.
console.log(JSON.stringify({ loadAverage: loadavg() }));
const forms = (process.env.FORMS || 'ranges,packed').split(',');
for (const file of files) {
  const { child, url: printed } = await serve(file);
  const total = statSync(file).size;
  // The printed URL opens the packed form where there is one; ?src=NAME.cgc reads by ranges.
  const urls = { ranges: printed.replace(/\.cgcz$/, '.cgc'), packed: /\.cgcz$/.test(printed) ? printed : null };
  const url = urls.ranges;
  try {
    const chromium = process.env.THROTTLED === '0' ? null : await puppeteer.launch({ headless: true, protocolTimeout: 600_000, ...launch.chromium });
    for (const [form, mbit] of chromium ? forms.filter((f) => urls[f]).flatMap((f) => [50, 1000].map((m) => [f, m])) : []) {
      const page = await chromium.newPage();
      let transferred = 0;
      const cdp = await page.createCDPSession();
      await cdp.send('Network.enable');
      await cdp.send('Network.setCacheDisabled', { cacheDisabled: true });
      // Bytes of the .cgc's responses only (not the page and its bundle), headers included.
      const cgc = new Set();
      cdp.on('Network.requestWillBeSent', (e) => /\.cgcz?$/.test(new URL(e.request.url).pathname) && cgc.add(e.requestId));
      cdp.on('Network.loadingFinished', (e) => cgc.has(e.requestId) && (transferred += e.encodedDataLength));
      // The packed form downloads in the rebuild's worker (packed-worker.ts): its requests are the
      // worker's, seen through a session of its own, attached before it runs.
      cdp.on('Target.attachedToTarget', async ({ sessionId, targetInfo, waitingForDebugger }) => {
        const session = cdp.connection().session(sessionId);
        if (targetInfo.type === 'worker' && session) {
          session.on('Network.requestWillBeSent', (e) => /\.cgcz?$/.test(new URL(e.request.url).pathname) && cgc.add(e.requestId));
          session.on('Network.loadingFinished', (e) => cgc.has(e.requestId) && (transferred += e.encodedDataLength));
          await session.send('Network.enable').catch(() => {});
          await session.send('Network.setCacheDisabled', { cacheDisabled: true }).catch(() => {});
        }
        if (waitingForDebugger && session) await session.send('Runtime.runIfWaitingForDebugger').catch(() => {});
      });
      await cdp.send('Target.setAutoAttach', { autoAttach: true, waitForDebuggerOnStart: true, flatten: true });
      await cdp.send('Network.emulateNetworkConditions', { offline: false, latency: 1, downloadThroughput: (mbit * 1e6) / 8, uploadThroughput: (mbit * 1e6) / 8 });
      await page.goto(`${urls[form]}&view=2&size=${size}`);
      // Polled rather than awaited in one call: a frame on a CPU adapter can take minutes.
      const withinMemory = await waitReady(chromium, page, capMs);
      const s = await page.evaluate(() => window.isogrid.stats);
      if (!withinMemory) {
        // The figures so far (first frame, last byte), then no further load in this browser.
        console.log(JSON.stringify({ file, form, total, browser: 'chromium', mbit, firstFrameMs: s.firstFrameAt ?? null, lastByteMs: s.completeAt ?? null, firstFrameBytes: s.firstFrameBytes ?? null, transferred, error: `over ${maxRss / 2 ** 30} GiB of memory` }));
        break;
      }
      if (s.error) throw new Error(`${file}: ${s.error}`);
      console.log(JSON.stringify({ file, form, total, browser: 'chromium', mbit, firstFrameMs: s.firstFrameAt, lastByteMs: s.completeAt, completeMs: s.readyAt ?? null, firstFrameBytes: s.firstFrameBytes, transferred, deviceMs: s.deviceAt, headerMs: s.headerAt, compiledMs: s.compiledAt, pages: s.pages, frames: s.frames, frameLog: s.frameLog }));
      await page.close();
    }
    await chromium?.close();
    for (const name of browsers) {
      const browser = await puppeteer.launch({ headless: true, protocolTimeout: 600_000, ...launch[name] });
      try {
        const page = await browser.newPage();
        await page.goto(`${url}&view=2&size=${size}`);
        if (!(await waitReady(browser, page, capMs))) {
          console.log(JSON.stringify({ file, browser: name, size, error: `over ${maxRss / 2 ** 30} GiB of memory` }));
          continue;
        }
        // Unthrottled load on 127.0.0.1 (ms from navigation start), then the frame time.
        const s = await page.evaluate(() => window.isogrid.stats);
        const f = await page.evaluate((n) => window.isogrid.frames(n), frames);
        // Frames of the view drawn again (the visibility bits of the last frame hold) and first
        // frames of a view (every cluster visible, as after a camera move).
        const fresh = await page.evaluate((n) => window.isogrid.frames(n, true), frames);
        console.log(JSON.stringify({ file, browser: name, adapter: s.adapter, size, firstFrameMs: s.firstFrameAt, lastByteMs: s.completeAt, completeMs: s.readyAt ?? null, redraw: f, firstOfView: fresh }));
      } finally {
        await browser.close();
      }
    }
  } finally {
    child.kill();
  }
}
console.log(JSON.stringify({ loadAverage: loadavg() }));
