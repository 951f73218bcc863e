"""Drops files on the isogrid viewer's window the way a file manager does: an XDND source
(https://freedesktop.org/wiki/Specifications/XDND, version 5) that offers `text/uri-list`.

    python3 xdnd_drop.py FILE...

Waits for a mapped top-level window that is XdndAware (the viewer; eframe maps its window only
after the first frame is painted, so the app is ready then), owns XdndSelection, sends
XdndEnter and XdndPosition, answers the target's selection request with the files' file://
URIs, sends XdndDrop and waits for XdndFinished. Exits 0 when the target accepted the drop,
1 with a one-line reason otherwise, 3 when python-xlib is missing (the caller skips then).
Used by crates/isogrid-cli/tests/it/view.rs under Xvfb; xdotool cannot act as an XDND source.
"""

import os
import select
import sys
import time
import urllib.parse

try:
    from Xlib import X, display, error
    from Xlib.protocol import event
except ImportError:
    print("xdnd: python-xlib is not installed (pip install python-xlib)", file=sys.stderr)
    sys.exit(3)

XDND_VERSION = 5
WINDOW_TIMEOUT = 120.0
REPLY_TIMEOUT = 30.0


def fail(message):
    print(f"xdnd: {message}", file=sys.stderr)
    sys.exit(1)


class Source:
    def __init__(self, paths):
        self.display = display.Display()
        self.root = self.display.screen().root
        atom = self.display.intern_atom
        self.atoms = {
            name: atom(name)
            for name in [
                "XdndAware",
                "XdndSelection",
                "XdndEnter",
                "XdndPosition",
                "XdndStatus",
                "XdndDrop",
                "XdndFinished",
                "XdndLeave",
                "XdndActionCopy",
                "text/uri-list",
                "TARGETS",
                "ATOM",
            ]
        }
        # Percent-encoded absolute paths, CRLF-terminated, as RFC 2483 lists URIs.
        uris = ["file://" + urllib.parse.quote(os.path.abspath(p)) for p in paths]
        self.uri_list = "".join(u + "\r\n" for u in uris).encode()
        # An unmapped window of our own: XDND messages name the source window, and the
        # selection needs an owner.
        self.window = self.root.create_window(0, 0, 1, 1, 0, X.CopyFromParent)
        self.selection_served = False

    def find_target(self):
        deadline = time.monotonic() + WINDOW_TIMEOUT
        while time.monotonic() < deadline:
            target = self._search(self.root, depth=0)
            if target is not None:
                return target
            time.sleep(0.2)
        fail(f"no mapped XdndAware window appeared within {WINDOW_TIMEOUT:.0f} s")

    def _search(self, window, depth):
        try:
            children = window.query_tree().children
        except error.XError:
            return None
        for child in children:
            try:
                if child.get_attributes().map_state != X.IsViewable:
                    continue
                aware = child.get_full_property(self.atoms["XdndAware"], X.AnyPropertyType)
            except error.XError:
                continue  # the window went away while we looked
            if aware is not None:
                return child
            if depth < 2:  # a window manager reparents clients into frames
                found = self._search(child, depth + 1)
                if found is not None:
                    return found
        return None

    def send(self, target, name, data):
        message = event.ClientMessage(
            window=target,
            client_type=self.atoms[name],
            data=(32, (data + [0] * 5)[:5]),
        )
        target.send_event(message, event_mask=0)
        self.display.flush()

    def next_event(self, deadline):
        while True:
            if self.display.pending_events():
                return self.display.next_event()
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            select.select([self.display.fileno()], [], [], left)

    def serve_selection(self, request):
        """Answers a ConvertSelection of XdndSelection: the URI list, or a refusal."""
        prop = request.property or request.target
        if request.target == self.atoms["text/uri-list"]:
            request.requestor.change_property(prop, request.target, 8, self.uri_list)
            self.selection_served = True
        elif request.target == self.atoms["TARGETS"]:
            offered = [self.atoms["text/uri-list"], self.atoms["TARGETS"]]
            request.requestor.change_property(prop, self.atoms["ATOM"], 32, offered)
        else:
            prop = X.NONE
        reply = event.SelectionNotify(
            time=request.time,
            requestor=request.requestor,
            selection=request.selection,
            target=request.target,
            property=prop,
        )
        request.requestor.send_event(reply, event_mask=0)
        self.display.flush()

    def wait_for(self, name, target):
        """Handles events until the target sends `name`; returns its data."""
        deadline = time.monotonic() + REPLY_TIMEOUT
        while True:
            ev = self.next_event(deadline)
            if ev is None:
                self.send(target, "XdndLeave", [self.window.id])
                fail(f"no {name} from window {target.id:#x} within {REPLY_TIMEOUT:.0f} s")
            if ev.type == X.SelectionRequest:
                self.serve_selection(ev)
            elif ev.type == X.ClientMessage and ev.client_type == self.atoms[name]:
                return ev.data[1]

    def drop(self):
        target = self.find_target()
        self.window.set_selection_owner(self.atoms["XdndSelection"], X.CurrentTime)
        if self.display.get_selection_owner(self.atoms["XdndSelection"]) != self.window:
            fail("could not own XdndSelection")
        geometry = target.get_geometry()
        centre = self.root.translate_coords(target, geometry.width // 2, geometry.height // 2)
        x, y = centre.x, centre.y

        self.send(target, "XdndEnter", [
            self.window.id,
            XDND_VERSION << 24,  # bit 0 clear: all types are in this message
            self.atoms["text/uri-list"],
        ])
        self.send(target, "XdndPosition", [
            self.window.id,
            0,
            (x << 16) | y,
            X.CurrentTime,
            self.atoms["XdndActionCopy"],
        ])
        status = self.wait_for("XdndStatus", target)
        if not status[1] & 1:
            self.send(target, "XdndLeave", [self.window.id])
            fail(f"window {target.id:#x} refused the drop")
        # The target asks for the data when the pointer first moves over it; serving it before
        # the drop lets the target know the files by the time XdndDrop arrives (events from one
        # client reach another in order).
        deadline = time.monotonic() + REPLY_TIMEOUT
        while not self.selection_served:
            ev = self.next_event(deadline)
            if ev is None:
                fail("the target never asked for the dropped data")
            if ev.type == X.SelectionRequest:
                self.serve_selection(ev)
        self.send(target, "XdndDrop", [self.window.id, 0, X.CurrentTime])
        finished = self.wait_for("XdndFinished", target)
        if not finished[1] & 1:
            fail(f"window {target.id:#x} did not accept the drop")
        print(f"xdnd: dropped {len(self.uri_list.splitlines())} file(s) on window {target.id:#x}")


def main():
    if len(sys.argv) < 2:
        fail("usage: xdnd_drop.py FILE...")
    Source(sys.argv[1:]).drop()


if __name__ == "__main__":
    main()
