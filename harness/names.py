"""ROS names: one validator for every graph name the harness takes or makes (topic, service
and action names, namespaces, single name segments such as a robot's namespace in a world).

The rules are ROS 2's (``rcl_validate_topic_name``, ``rmw_validate_namespace``,
``rmw_validate_node_name``), so a name the harness accepts is one a real ROS 2 graph and the
bridge accept too:

- tokens are ASCII letters, digits and ``_``, and do not start with a digit;
- tokens are separated by single ``/``; a name does not end with ``/``;
- ``~`` (the private namespace) only as the whole first token (``~`` or ``~/x``), and only in
  a topic, service or action name;
- substitutions (``{node}``) are not supported and refused.

Package and ``model://`` names (folder names, with ``-`` and ``.`` in real packages such as
``example-robot-data``) are not graph names: :func:`package_problem` checks them.

This module imports only the standard library (the sans-I/O bridge core and the pytest plugin
use it).
"""

from __future__ import annotations

import re
from typing import Literal

__all__ = [
    "NAME_KINDS",
    "InvalidNameError",
    "NameKind",
    "check_name",
    "name_problem",
    "package_problem",
]

NameKind = Literal["topic", "namespace", "segment"]
"""``topic``: a topic, service or action name, relative or absolute (``~`` allowed);
``namespace``: a namespace, relative or absolute (a leading or trailing ``/`` tolerated);
``segment``: one token (a node name, a robot's namespace in a world of several)."""
NAME_KINDS: tuple[NameKind, ...] = ("topic", "namespace", "segment")

_TOKEN = re.compile(r"[A-Za-z0-9_]+")
_PACKAGE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-]*")


class InvalidNameError(ValueError):
    """A ROS name breaks ROS 2's rules (the message says which, in one line)."""


def _token_problem(token: str) -> str | None:
    if not token:
        return "has an empty token ('//', or a leading/trailing '/')"
    if not _TOKEN.fullmatch(token):
        bad = next(c for c in token if not (c.isascii() and (c.isalnum() or c == "_")))
        return f"has {bad!r}: ROS names are ASCII letters, digits, '_' and '/'"
    if token[0].isdigit():
        return f"has a token starting with a digit ({token!r})"
    return None


def name_problem(value: object, kind: NameKind = "topic") -> str | None:
    """Why ``value`` is not a valid ROS name of ``kind`` (a short phrase), or None if it is."""
    if not isinstance(value, str):
        return f"is not a string ({type(value).__name__})"
    if not value:
        return "is empty"
    if kind == "segment":
        if "/" in value:
            return "has '/': it must be one name segment"
        return _token_problem(value)
    text = value
    if kind == "namespace":
        text = value.strip("/")
        if not text:
            return "is only '/'"
    elif kind == "topic":
        if text.endswith("/") and text != "/":
            return "ends with '/'"
        if text.startswith("~"):
            if text == "~":
                return None
            if not text.startswith("~/"):
                return "has '~' not followed by '/' (the private namespace is '~/name')"
            text = text[2:]
        elif text.startswith("/"):
            text = text[1:]
    else:
        raise ValueError(f"unknown name kind {kind!r} (one of {', '.join(NAME_KINDS)})")
    for token in text.split("/"):
        problem = _token_problem(token)
        if problem is not None:
            return problem
    return None


def check_name(
    value: object,
    what: str,
    kind: NameKind = "topic",
    error: type[Exception] = InvalidNameError,
) -> str:
    """``value`` if it is a valid ROS name of ``kind``, else ``error`` with one line naming
    ``what`` (e.g. ``"namespace"``, ``"joint_command_topic['arm']"``), the value and the rule
    it breaks."""
    problem = name_problem(value, kind)
    if problem is not None:
        raise error(f"{what} {value!r} is not a valid ROS name: it {problem}")
    assert isinstance(value, str)
    return value


def package_problem(value: str) -> str | None:
    """Why ``value`` is not a usable ``package://`` or ``model://`` name (a folder name:
    letters, digits, ``_``, ``-``, ``.``, not starting with ``-`` or ``.``), or None."""
    if not value:
        return "is empty"
    if not _PACKAGE.fullmatch(value):
        return "is not letters, digits, '_', '-' and '.' (not starting with '-' or '.')"
    return None
