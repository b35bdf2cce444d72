"""Drives headless Chromium through the DevTools protocol for the view
tests: opens URL, then runs each step in order and prints one JSON line per
`eval` (its value).

    page.py URL STEP...
      wait:EXPR   until the JavaScript EXPR is true (at most 60 s)
      eval:EXPR   print the value of EXPR as a JSON line
      click:EXPR  a mouse click (pressed, released) at the page point [x, y]
                  that the JavaScript EXPR gives
      shot:FILE   a PNG screenshot of the page
      mark:FILE   writes FILE (empty): tells a caller waiting for it that
                  the steps before it are done
      size:WxH    the window's size (before the URL loads: 1200x800)

A wait that times out says what the page showed then (its status line,
how many records it has) and any script error the page threw; script
errors are said on stderr at the end too.

Chromium is `$RADAR_CHROMIUM`, else `chromium` (Debian's package, which
.ci/debian-packages installs). It gets a fresh profile and a debugging port
on 127.0.0.1 that the kernel picks, and is stopped when the steps end.
"""

import base64
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.request

import websocket

TIMEOUT = 60.0


class Page:
    def __init__(self, ws):
        self.ws = ws
        self.next_id = 0
        # Uncaught script errors the page threw (Runtime.exceptionThrown).
        self.errors = []

    def call(self, method, **params):
        self.next_id += 1
        ask = self.next_id
        self.ws.send(json.dumps({"id": ask, "method": method, "params": params}))
        while True:
            message = json.loads(self.ws.recv())
            if message.get("method") == "Runtime.exceptionThrown":
                details = message["params"]["exceptionDetails"]
                exception = details.get("exception", {})
                self.errors.append(exception.get("description") or details.get("text"))
            if message.get("id") == ask:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message.get("result", {})

    def evaluate(self, expression):
        result = self.call(
            "Runtime.evaluate",
            expression=expression,
            returnByValue=True,
            awaitPromise=True,
        )
        if "exceptionDetails" in result:
            details = result["exceptionDetails"]
            text = details.get("exception", {}).get("description") or details.get("text")
            raise RuntimeError(f"`{expression}` threw: {text}")
        return result.get("result", {}).get("value")

    def wait(self, expression, what):
        deadline = time.monotonic() + TIMEOUT
        while True:
            try:
                if self.evaluate(f"!!({expression})") is True:
                    return
            except RuntimeError:
                pass  # the page may still be loading
            if time.monotonic() > deadline:
                raise SystemExit(f"page.py: waited {TIMEOUT:.0f} s for {what}; {self.shown()}")
            time.sleep(0.05)

    def shown(self):
        """What the page shows, for a wait that timed out."""
        try:
            status = self.evaluate(
                "[document.getElementById('status')?.textContent, document.body?.dataset.records]"
            )
        except Exception as e:  # a page that hangs times out the socket too
            status = str(e)
        return f"the page showed {json.dumps(status)}; its script errors: {json.dumps(self.errors)}"


def start_chromium(profile, size):
    chromium = os.environ.get("RADAR_CHROMIUM") or shutil.which("chromium")
    if not chromium:
        raise SystemExit("page.py: no chromium (run .ci/debian-packages)")
    args = [
        chromium,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--hide-scrollbars",
        "--no-first-run",
        "--remote-debugging-address=127.0.0.1",
        "--remote-debugging-port=0",
        f"--user-data-dir={profile}",
        f"--window-size={size}",
        "about:blank",
    ]
    process = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    port_file = os.path.join(profile, "DevToolsActivePort")
    deadline = time.monotonic() + TIMEOUT
    while not os.path.exists(port_file) or not open(port_file).read().strip():
        if process.poll() is not None or time.monotonic() > deadline:
            raise SystemExit("page.py: chromium did not open its debugging port")
        time.sleep(0.05)
    port = int(open(port_file).read().split()[0])
    while True:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as r:
            pages = [t for t in json.load(r) if t.get("type") == "page"]
        if pages:
            return process, pages[0]["webSocketDebuggerUrl"]
        if time.monotonic() > deadline:
            raise SystemExit("page.py: chromium has no page")
        time.sleep(0.05)


def main():
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    url, steps = sys.argv[1], sys.argv[2:]
    size = "1200,800"
    for step in steps:
        if step.startswith("size:"):
            size = step[5:].replace("x", ",")
    profile = tempfile.mkdtemp(prefix="radar-chromium-")
    process = None
    try:
        process, ws_url = start_chromium(profile, size)
        page = Page(websocket.create_connection(ws_url, timeout=TIMEOUT, suppress_origin=True))
        page.call("Page.enable")
        page.call("Runtime.enable")
        page.call("Page.navigate", url=url)
        page.wait("document.readyState === 'complete' && window.radar !== undefined", "the page")
        for step in steps:
            kind, _, arg = step.partition(":")
            if kind == "wait":
                page.wait(arg, f"`{arg}`")
            elif kind == "eval":
                print(json.dumps(page.evaluate(arg)), flush=True)
            elif kind == "click":
                x, y = page.evaluate(arg)
                for event in ("mousePressed", "mouseReleased"):
                    page.call(
                        "Input.dispatchMouseEvent",
                        type=event,
                        x=x,
                        y=y,
                        button="left",
                        clickCount=1,
                    )
            elif kind == "mark":
                open(arg, "w").close()
            elif kind == "shot":
                png = page.call("Page.captureScreenshot", format="png")["data"]
                with open(arg, "wb") as f:
                    f.write(base64.b64decode(png))
            elif kind != "size":
                raise SystemExit(f"page.py: unknown step `{step}`")
        # Script errors do not fail the steps (a test asserts what the page
        # shows), but are said.
        for error in page.errors:
            print(f"page.py: the page threw: {error}", file=sys.stderr)
    finally:
        if process is not None:
            process.terminate()
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
        shutil.rmtree(profile, ignore_errors=True)


if __name__ == "__main__":
    main()
