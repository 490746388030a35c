"""Meshes of a played recording, served over HTTP on 127.0.0.1 so a viewer shows the robot.

A URDF's ``package://`` (or relative) mesh references mean nothing on a machine without the
robot's package; the recording carries the mesh files (:mod:`harness.recording.meshes`).
While a recording plays, :class:`AssetServer` serves them (stdlib ``http.server`` in a
daemon thread, loopback only, ``Access-Control-Allow-Origin: *`` for a browser-based viewer
such as Foxglove) and :func:`rewrite_mesh_uris` points the played ``robot_description`` at
them. The recording itself is never changed: its description stays as the robot published it.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Mapping
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import quote, unquote, urlsplit

from harness.recording import mesh_attachment_name

__all__ = ["AssetServer", "rewrite_mesh_uris"]

_MESH = re.compile(r"(<mesh\b[^>]*?\bfilename\s*=\s*)(\"[^\"]*\"|'[^']*')")


def rewrite_mesh_uris(text: str, base_url: str, names: Mapping[str, bytes]) -> str:
    """``text`` (URDF) with each ``<mesh filename>`` whose file is among ``names`` (the
    recording's attachments) replaced by its URL under ``base_url``; other references stay."""

    def replace(match: re.Match[str]) -> str:
        quoted = match.group(2)
        name = mesh_attachment_name(quoted[1:-1])
        if name is None or name not in names:
            return match.group(0)
        return f'{match.group(1)}"{base_url}/{quote(name)}"'

    return _MESH.sub(replace, text)


class AssetServer:
    """Serve ``files`` (name -> bytes) at ``http://127.0.0.1:PORT/<name>`` (port 0: any free
    one); :meth:`close` stops it."""

    def __init__(self, files: Mapping[str, bytes], *, port: int = 0) -> None:
        served = dict(files)

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                name = unquote(urlsplit(self.path).path.lstrip("/"))
                blob = served.get(name)
                if blob is None:
                    self.send_error(404, f"no attachment {name!r}")
                    return
                self.send_response(200)
                self.send_header("Content-Type", "application/octet-stream")
                self.send_header("Content-Length", str(len(blob)))
                self.send_header("Access-Control-Allow-Origin", "*")
                self.end_headers()
                self.wfile.write(blob)

            def log_message(self, format: str, *args: object) -> None:
                pass  # quiet: the player prints its own lines

        self._server = ThreadingHTTPServer(("127.0.0.1", port), Handler)
        self._server.daemon_threads = True
        self.url = f"http://127.0.0.1:{self._server.server_address[1]}"
        self._thread = threading.Thread(
            target=self._server.serve_forever, name="harness-assets", daemon=True
        )
        self._thread.start()

    def close(self) -> None:
        """Stop serving."""
        self._server.shutdown()
        self._server.server_close()
        self._thread.join()
