#!/usr/bin/env python3
"""The web viewer's frame time in Chromium, driven over the DevTools protocol on a pipe.

For machines with Chromium but no node (the lent GPU machine): `isogrid serve FILE` on
127.0.0.1, the page opened at `&view=V&size=WxH`, and once its picture is complete, the page's own
`window.isogrid.frames(n)` (the view drawn again) and `frames(n, true)` (first frames of a view)
— the same measurement `web/bench/bench.mjs` takes through puppeteer. Prints one JSON object per
file and view.

    python3 web/bench/gpu_frame.py --chromium PATH --exe isogrid [--size 1920x1080] FILE.cgc...

CHROMIUM_FLAGS (space-separated) replaces the default flags after --headless=new, e.g. to pick
the Vulkan backend on an NVIDIA machine.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

DEFAULT_FLAGS = "--no-sandbox --enable-unsafe-webgpu"


class DevTools:
    """A Chromium started with --remote-debugging-pipe: requests on fd 3, replies and events on fd 4."""

    def __init__(self, chromium, flags, profile):
        to_chrome_r, self.to_chrome = os.pipe()
        self.from_chrome, from_chrome_w = os.pipe()

        def wire():
            # Through high numbers first: either pipe end may itself be fd 3 or 4.
            os.dup2(to_chrome_r, 100)
            os.dup2(from_chrome_w, 101)
            os.dup2(100, 3)
            os.dup2(101, 4)

        self.process = subprocess.Popen(
            [chromium, "--headless=new", "--remote-debugging-pipe", f"--user-data-dir={profile}"] + flags,
            preexec_fn=wire, pass_fds=(3, 4),
            stdout=subprocess.DEVNULL, stderr=open(os.path.join(profile, "stderr.log"), "wb"))
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        self.next_id = 0
        self.buffer = b""

    def send(self, method, params=None, session=None):
        self.next_id += 1
        message = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        os.write(self.to_chrome, json.dumps(message).encode() + b"\0")
        while True:
            while b"\0" not in self.buffer:
                chunk = os.read(self.from_chrome, 1 << 20)
                if not chunk:
                    raise RuntimeError("chromium closed its DevTools pipe")
                self.buffer += chunk
            raw, self.buffer = self.buffer.split(b"\0", 1)
            reply = json.loads(raw)
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply["result"]

    def evaluate(self, session, expression):
        r = self.send("Runtime.evaluate", {"expression": expression, "awaitPromise": True, "returnByValue": True}, session)
        if "exceptionDetails" in r:
            raise RuntimeError(f"{expression}: {r['exceptionDetails']}")
        return r["result"].get("value")

    def close(self):
        try:
            self.send("Browser.close")
        except (RuntimeError, OSError):
            self.process.kill()
        self.process.wait()


def serve(exe, file):
    child = subprocess.Popen([exe, "serve", file, "--port", "0"], stdout=subprocess.PIPE, text=True)
    line = child.stdout.readline()
    url = next(w for w in line.split() if w.startswith("http://"))
    return child, url


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--chromium", default="/usr/lib/chromium/chromium")
    ap.add_argument("--exe", required=True, help="the isogrid binary")
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--views", default="1,2")
    ap.add_argument("--cap-s", type=float, default=600, help="seconds a load may take to its complete picture")
    ap.add_argument("files", nargs="+")
    args = ap.parse_args()
    flags = os.environ.get("CHROMIUM_FLAGS", DEFAULT_FLAGS).split()
    with tempfile.TemporaryDirectory(ignore_cleanup_errors=True) as profile:
        tools = DevTools(args.chromium, flags, profile)
        failed, failed_views = True, 0
        try:
            for file in args.files:
                server, url = serve(args.exe, file)
                try:
                    for view in args.views.split(","):
                        target = tools.send("Target.createTarget", {"url": "about:blank"})["targetId"]
                        session = tools.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
                        tools.send("Page.navigate", {"url": f"{url}&view={view}&size={args.size}"}, session)
                        until = time.monotonic() + args.cap_s
                        while True:
                            done = tools.evaluate(session, "Boolean(window.isogrid && (window.isogrid.stats.readyAt || window.isogrid.stats.error))")
                            if done or time.monotonic() > until:
                                break
                            time.sleep(0.5)
                        stats = tools.evaluate(session, "window.isogrid.stats")
                        if stats.get("error") or not stats.get("readyAt"):
                            failed_views += 1
                            print(json.dumps({"file": file, "view": view, "error": stats.get("error") or f"not complete in {args.cap_s} s", "adapter": stats.get("adapter")}), flush=True)
                        else:
                            redraw = tools.evaluate(session, f"window.isogrid.frames({args.frames})")
                            fresh = tools.evaluate(session, f"window.isogrid.frames({args.frames}, true)")
                            print(json.dumps({"file": os.path.basename(file), "view": view, "size": args.size, "adapter": stats.get("adapter"),
                                              "firstFrameMs": stats.get("firstFrameAt"), "completeMs": stats.get("readyAt"), "pages": stats.get("pages"),
                                              "redraw": redraw, "firstOfView": fresh}), flush=True)
                        tools.send("Target.closeTarget", {"targetId": target})
                finally:
                    server.kill()
                    server.wait()
            failed = failed_views > 0
        finally:
            tools.close()
            if failed:  # Chromium's own account of why, e.g. no WebGPU adapter
                sys.stderr.write(open(os.path.join(profile, "stderr.log"), errors="replace").read()[-6000:])


if __name__ == "__main__":
    main()
