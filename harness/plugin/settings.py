"""The plugin's command-line options, their ini twins, and :class:`HarnessSettings` (the options
resolved once per pytest run, kept in the config's stash under :data:`SETTINGS`).

This module imports only the standard library, pytest and :mod:`harness.vocabulary`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from harness.vocabulary import ACTUATION_INPUTS, ACTUATIONS, Actuation

__all__ = [
    "GOLDEN_SOURCES",
    "KEEP_CHOICES",
    "MODE_CHOICES",
    "PLUGIN_MODULE",
    "SETTINGS",
    "HarnessSettings",
    "add_options",
    "resolve_settings",
]

KEEP_CHOICES = ("always", "failed", "never")
GOLDEN_SOURCES = ("carry", "project")
"""``--harness-golden-sources``' values (see :mod:`harness.plugin.golden_sources`)."""
MODE_CHOICES = ACTUATION_INPUTS
"""The deprecated ``--harness-mode``'s spellings (``position``/``dynamic`` mean ``servo``)."""
PLUGIN_MODULE = "harness.pytest_plugin"
"""The plugin's module: what ``-p`` loads when the ``pytest11`` entry point is not installed."""
_DEFAULT_RECORD_DIR = ".harness/recordings"
_DEFAULT_GOLDEN_DIR = "recordings"


@dataclass(frozen=True)
class HarnessSettings:
    """The plugin's options, resolved (command line first, then ini)."""

    rootdir: Path
    record_dir: Path
    keep_recordings: str
    update_goldens: bool
    strict_bridge: bool
    actuation: Actuation | None
    golden_dir: Path
    golden_sources: str
    """``carry`` (default) or ``project``: see :mod:`harness.plugin.golden_sources`."""
    plugin_args: tuple[str, ...]
    """Arguments that load this plugin when it is not installed as an entry point."""


SETTINGS = pytest.StashKey[HarnessSettings]()
"""Where :func:`resolve_settings`' result is kept: ``config.stash[SETTINGS]``."""


def _add(
    parser: pytest.Parser,
    group: pytest.OptionGroup,
    flag: str,
    ini: str,
    help: str,
    *,
    kind: str = "string",
    default: Any = None,
    choices: tuple[str, ...] | None = None,
) -> None:
    if kind == "bool":
        group.addoption(flag, action="store_true", dest=ini, default=None, help=help)
    else:
        group.addoption(flag, dest=ini, default=None, choices=choices, help=help)
    parser.addini(ini, f"{help} (ini twin of {flag})", type=kind, default=default)  # type: ignore[arg-type]


def add_options(parser: pytest.Parser) -> None:
    """Register the harness options and their ini twins (``pytest_addoption``)."""
    group = parser.getgroup("harness", "harness: simulated robots on rosbridge, recorded")
    _add(
        parser,
        group,
        "--harness-record-dir",
        "harness_record_dir",
        f"where test recordings go (default: <rootdir>/{_DEFAULT_RECORD_DIR})",
        default="",
    )
    _add(
        parser,
        group,
        "--harness-keep-recordings",
        "harness_keep_recordings",
        "keep recordings of always, failed (default) or never any tests",
        default="failed",
        choices=KEEP_CHOICES,
    )
    _add(
        parser,
        group,
        "--harness-update-goldens",
        "harness_update_goldens",
        "write or overwrite golden recordings instead of comparing with them",
        kind="bool",
        default=False,
    )
    _add(
        parser,
        group,
        "--harness-strict-bridge",
        "harness_strict_bridge",
        "fail a test whose bridge answered a client with an error status",
        kind="bool",
        default=False,
    )
    _add(
        parser,
        group,
        "--harness-actuation",
        "harness_actuation",
        "run every session with every joint kinematic, or as a servo: every kinematic joint "
        "a position servo (velocity and effort joints kept)",
        default="",
        choices=ACTUATIONS,
    )
    _add(
        parser,
        group,
        "--harness-mode",
        "harness_mode",
        "deprecated spelling of --harness-actuation (position and dynamic mean servo)",
        default="",
        choices=MODE_CHOICES,
    )
    _add(
        parser,
        group,
        "--harness-golden-dir",
        "harness_golden_dir",
        f"where golden recordings are (default: <rootdir>/{_DEFAULT_GOLDEN_DIR})",
        default="",
    )
    _add(
        parser,
        group,
        "--harness-golden-sources",
        "harness_golden_sources",
        "goldens carry the robot's source files (carry, default), or refer to the files of "
        "this project by content hash (project): such goldens are checked only by pytest here",
        default="carry",
        choices=GOLDEN_SOURCES,
    )


def _choice(config: pytest.Config, name: str, choices: tuple[str, ...], default: str) -> str:
    value = config.getoption(name)
    if value is None:
        value = str(config.getini(name)).strip() or default
        if value not in choices:
            raise pytest.UsageError(
                f"ini option {name} = {value!r}: must be one of {', '.join(choices)}"
            )
    return str(value)


def _actuation(config: pytest.Config) -> Actuation | None:
    """``--harness-actuation``, or the deprecated ``--harness-mode`` with a warning."""
    actuation = _choice(config, "harness_actuation", ("", *ACTUATIONS), "")
    old = _choice(config, "harness_mode", ("", *MODE_CHOICES), "")
    if old:
        new = Actuation.parse(old).value
        if actuation and actuation != new:
            raise pytest.UsageError(
                f"--harness-mode {old} and --harness-actuation {actuation} disagree "
                "(--harness-mode is the deprecated spelling: give only --harness-actuation)"
            )
        config.issue_config_time_warning(
            pytest.PytestDeprecationWarning(
                f"--harness-mode / harness_mode is deprecated: use --harness-actuation {new}"
            ),
            stacklevel=2,
        )
        actuation = new
    return Actuation(actuation) if actuation else None


def _flag(config: pytest.Config, name: str) -> bool:
    value = config.getoption(name)
    return bool(config.getini(name)) if value is None else bool(value)


def _folder(config: pytest.Config, name: str, default: str) -> Path:
    """A folder option: relative to the invocation directory on the command line, to the
    rootdir in the ini file."""
    value = config.getoption(name)
    if value is not None:
        return (config.invocation_params.dir / str(value)).resolve()
    return (config.rootpath / (str(config.getini(name)).strip() or default)).resolve()


def _worker_id(config: pytest.Config) -> str | None:
    workerinput = getattr(config, "workerinput", None)
    if isinstance(workerinput, dict):
        return str(workerinput.get("workerid", "gw"))
    return None


def resolve_settings(config: pytest.Config) -> HarnessSettings:
    """The options of this run (command line first, then ini; one record folder per xdist
    worker); a bad ini value raises :class:`pytest.UsageError` naming it."""
    actuation = _actuation(config)
    record_dir = _folder(config, "harness_record_dir", _DEFAULT_RECORD_DIR)
    worker = _worker_id(config)
    if worker is not None:
        record_dir = record_dir / worker
    from_entry_point = config.pluginmanager.get_plugin("harness") is not None
    return HarnessSettings(
        rootdir=config.rootpath,
        record_dir=record_dir,
        keep_recordings=_choice(config, "harness_keep_recordings", KEEP_CHOICES, "failed"),
        update_goldens=_flag(config, "harness_update_goldens"),
        strict_bridge=_flag(config, "harness_strict_bridge"),
        actuation=actuation,
        golden_dir=_folder(config, "harness_golden_dir", _DEFAULT_GOLDEN_DIR),
        golden_sources=_choice(config, "harness_golden_sources", GOLDEN_SOURCES, "carry"),
        plugin_args=() if from_entry_point else ("-p", PLUGIN_MODULE),
    )
