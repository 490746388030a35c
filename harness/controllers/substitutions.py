"""Launch substitutions in a controllers YAML: ``$(var NAME)`` as ``ros2 launch`` expands it.

A robot project's controllers file is often written for its launch file
(``joints: [$(var joint_prefix)1]``) and loaded with substitutions allowed
(``ParameterFile(..., allow_substs=True)``). The text is expanded before it is parsed, as launch
does, from the arguments given (``--controllers-arg NAME:=VALUE``, ``controllers_args=``, a
scenario's ``controllers_args:``). A name without a value, or a substitution other than
``var``, is one line naming it, the file and the line.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

import yaml  # type: ignore[import-untyped,unused-ignore]

from harness.controllers.errors import ControllersConfigError

__all__ = ["ARG_NAME", "check_args", "substitute", "substitute_tree"]

ARG_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
"""What a launch argument's name may be."""
_SUBST = re.compile(r"\$\(\s*([A-Za-z_][A-Za-z0-9_-]*)((?:\s+[^()\s]+)*)\s*\)")


def check_args(args: Mapping[str, object], where: str) -> dict[str, str]:
    """``args`` as name -> text; a name launch would not accept is one line (``where``: the
    option's spelling)."""
    out: dict[str, str] = {}
    for name, value in args.items():
        if not isinstance(name, str) or not ARG_NAME.match(name):
            raise ControllersConfigError(
                f"{where}: {name!r} is not an argument name (letters, digits and _)"
            )
        if isinstance(value, bool):
            out[name] = "true" if value else "false"
        elif isinstance(value, str | int | float):
            out[name] = str(value)
        else:
            raise ControllersConfigError(
                f"{where}: {name}: the value must be text or a number, not {value!r}"
            )
    return out


def substitute(text: str, args: Mapping[str, str], where: str, *, lines: bool = True) -> str:
    """``text`` with every ``$(var NAME)`` replaced by ``args[NAME]`` (``lines``: errors name
    the line of ``text``)."""

    def one(match: re.Match[str]) -> str:
        kind, rest = match.group(1), match.group(2).split()
        at = f"line {text.count(chr(10), 0, match.start()) + 1}: " if lines else ""
        if kind != "var" or len(rest) != 1:
            raise ControllersConfigError(
                f"{where}: {at}{match.group(0)} is not supported (only $(var NAME) is expanded)"
            )
        name = rest[0]
        if name not in args:
            given = ", ".join(sorted(args)) or "none"
            raise ControllersConfigError(
                f"{where}: {at}$(var {name}) has no value: give it with "
                f"--controllers-arg {name}:=VALUE (controllers_args={{'{name}': ...}}; "
                f"arguments given: {given})"
            )
        return args[name]

    return _SUBST.sub(one, text)


def substitute_tree(value: Any, args: Mapping[str, str], where: str) -> Any:
    """A parsed YAML tree (a scenario's inline ``controllers:``) with its strings expanded; a
    string that was one substitution is read as a YAML scalar (``$(var rate)`` -> 50), as the
    text form would read it."""
    if isinstance(value, Mapping):
        return {
            substitute_tree(k, args, where): substitute_tree(v, args, f"{where}.{k}")
            for k, v in value.items()
        }
    if isinstance(value, list | tuple):
        return [substitute_tree(v, args, where) for v in value]
    if isinstance(value, str) and "$(" in value:
        text = substitute(value, args, where, lines=False)
        if _SUBST.fullmatch(value.strip()):
            try:
                return yaml.safe_load(text)
            except yaml.YAMLError:
                return text
        return text
    return value
