"""A xacro expansion metered while it runs, against
:class:`~harness.models.files.limits.XacroLimits`.

xacro (the ROS package) expands a minidom DOM through a few module functions, looked up by
name at each call: ``eval_all`` (one element), ``eval_text`` (one attribute value or text),
``safe_eval`` (one ``${...}``), ``replace_node`` (a macro call, include, block or condition
replaced by its expansion), ``remove_previous_comments`` and ``parse`` (an included file).
:func:`metered` wraps each for the time of one expansion: every call counts its work, and
the first count over its limit stops the expansion with one
:class:`~harness.models.files.limits.ModelLimitError` line. Nothing is checked after the fact: a
file that asks for 4 million elements is stopped at the limit, not when it is done.

``safe_eval`` evaluates through :func:`harness.models.xacro.evaluate.guarded_eval`: one ``${...}``
is one Python ``eval``, so its steps are charged before they run, not its value after.

``replace_node`` is also made linear: xacro moves an expansion into its parent node by node
with minidom's ``insertBefore``, each move a scan of the parent's children, so an expansion
of n nodes costs n² (2 KB of doubling macros spent minutes on this alone, and two Franka arms
on one base 2.5 million scans). The splice here puts the same nodes in the same places, with
the same sibling links, in one pass; anything it does not expect goes to xacro's own.
"""

from __future__ import annotations

import itertools
import os
import stat
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, NoReturn

from harness.models.errors import XMLError
from harness.models.files.limits import XACRO_LIMIT_ENV, ModelLimitError, XacroLimits
from harness.models.files.xmlsafe import MAX_XML_BYTES
from harness.models.xacro.evaluate import guarded_eval, text_size

__all__ = ["XacroMeter", "metered"]

_ELEMENT = 1  # xml.dom.Node.ELEMENT_NODE
_TEXT = 3  # xml.dom.Node.TEXT_NODE


class XacroMeter:
    """What one expansion has done so far (elements, expressions, text, DOM work,
    nesting, time), each
    checked against ``limits`` as it grows. One meter may span several attempts (the
    search for every undefined argument re-expands): the counts and the clock add up."""

    def __init__(self, limits: XacroLimits) -> None:
        self.limits = limits
        self.deadline = time.monotonic() + limits.seconds
        self.elements = 0
        self.expressions = 0
        self.text_bytes = 0
        self.dom_work = 0
        self.depth = 0

    def _stop(self, what: str, field: str) -> NoReturn:
        raise ModelLimitError(
            f"xacro expansion stopped: {what} (the limit; {XACRO_LIMIT_ENV[field]} changes it)"
        )

    def refuse(self, what: str) -> NoReturn:
        """Stop the expansion: ``what`` (a step no limit variable allows) was asked for."""
        raise ModelLimitError(f"xacro expansion stopped: an expression asks for {what}")

    def tick(self) -> None:
        """Check the clock (the last guard: the counters stop any real bomb first)."""
        if time.monotonic() > self.deadline:
            self._stop(f"it ran longer than {self.limits.seconds:g} s", "seconds")

    def enter(self, node: Any) -> None:
        """One element about to be evaluated: count it, its nesting and its names (tag,
        attribute names, the comments and other non-text nodes it holds: text is counted
        when evaluated)."""
        self.elements += 1
        if self.elements > self.limits.elements:
            self._stop(f"more than {self.limits.elements} elements", "elements")
        self.depth += 1
        if self.depth > self.limits.depth:
            self._stop(
                f"elements and macro calls nested more than {self.limits.depth} deep", "depth"
            )
        size = len(getattr(node, "tagName", "") or "")
        attributes = getattr(node, "_attrs", None)
        if attributes:
            size += sum(len(name) for name in attributes)
        for child in getattr(node, "childNodes", ()):
            if child.nodeType not in (_ELEMENT, _TEXT):
                size += len(getattr(child, "data", "") or "") + len(child.nodeName or "")
        self.text(size)
        self.tick()

    def text(self, size: int) -> None:
        """``size`` more characters of text produced."""
        self.text_bytes += size
        if self.text_bytes > self.limits.text_bytes:
            self._stop(f"more than {self.limits.text_bytes} bytes of text", "text_bytes")

    def expression(self) -> None:
        """One ``${...}`` expression about to be evaluated."""
        self.expressions += 1
        if self.expressions > self.limits.expressions:
            self._stop(f"more than {self.limits.expressions} expressions", "expressions")

    def value(self, value: Any) -> None:
        """An expression's value: its text size as ``str()`` would write it, measured up to
        what is left of the budget (a value of shared references is never written out)."""
        self.text(text_size(value, self.limits.text_bytes - self.text_bytes))

    def work(self, scans: int) -> None:
        """``scans`` more sibling-list entries scanned or moved by DOM edits."""
        self.dom_work += scans
        if self.dom_work > self.limits.dom_work:
            self._stop(f"more than {self.limits.dom_work} DOM sibling scans", "dom_work")


def _splice(node: Any, by: Any, content_only: bool) -> int | None:
    """xacro's ``replace_node`` in one pass: ``by`` (a node, a list of nodes, or their
    children when ``content_only``) put where ``node`` is, and ``node`` removed. Returns the
    sibling entries scanned and moved, or None (nothing changed) for a case it leaves to
    xacro."""
    parent = node.parentNode
    if parent is None:
        return None
    docs = [] if by is None else (by if isinstance(by, list) else [by])
    new: list[Any] = []
    for doc in docs:
        if doc is parent:
            return None
        if content_only:
            new.extend(doc.childNodes)
        elif doc.parentNode is None and doc is not node:
            new.append(doc)
        else:
            return None
    allowed = parent._child_node_types
    if any(item is node or item is parent or item.nodeType not in allowed for item in new):
        return None
    after = 0
    probe = node.nextSibling
    while probe is not None:
        after += 1
        probe = probe.nextSibling
    siblings = parent.childNodes
    index = len(siblings) - 1 - after
    if index < 0 or siblings[index] is not node:
        return None
    if content_only:
        for doc in docs:
            del doc.childNodes[:]
    before, following = node.previousSibling, node.nextSibling
    siblings[index : index + 1] = new
    chain = [before, *new, following]
    for item in new:
        item.parentNode = parent
    for left, right in itertools.pairwise(chain):
        if left is not None:
            left.nextSibling = right
        if right is not None:
            right.previousSibling = left
    node.parentNode = node.previousSibling = node.nextSibling = None
    _clear_id_cache(parent)
    return after + len(new) + 1


def _clear_id_cache(node: Any) -> None:
    """What minidom does to its ``getElementById`` cache when elements move."""
    from xml.dom import minidom

    clear: Callable[[Any], None] | None = getattr(minidom, "_clear_id_cache", None)
    if clear is not None:
        clear(node)


@contextmanager
def metered(xacro_module: Any, meter: XacroMeter) -> Iterator[None]:
    """While the block runs, xacro's expansion functions count against ``meter`` (see the
    module docstring). Not reentrant: xacro's state is global and its caller holds a lock."""
    names = (
        "eval_all",
        "eval_text",
        "safe_eval",
        "replace_node",
        "remove_previous_comments",
        "parse",
    )
    original: dict[str, Any] = {name: getattr(xacro_module, name) for name in names}

    def eval_all(node: Any, macros: Any, symbols: Any) -> None:
        meter.enter(node)
        try:
            original["eval_all"](node, macros, symbols)
        finally:
            meter.depth -= 1

    def eval_text(text: Any, symbols: Any) -> Any:
        meter.tick()
        result = original["eval_text"](text, symbols)
        if isinstance(result, str):
            meter.text(len(result))
        return result

    def safe_eval(expr: str, globals: Any, locals: Any = None) -> Any:
        meter.expression()
        result = guarded_eval(expr, globals, locals, meter, xacro_module.XacroException)
        if not isinstance(result, str):  # eval_text counts strings
            meter.value(result)
        return result

    def replace_node(node: Any, by: Any, content_only: bool = False) -> None:
        scans = _splice(node, by, content_only)
        if scans is None:
            parent = node.parentNode
            moved = len(by) if isinstance(by, list) else 1
            meter.work((moved + 1) * (len(parent.childNodes) if parent is not None else 1))
            original["replace_node"](node, by, content_only)
        else:
            meter.work(scans)

    def remove_previous_comments(node: Any) -> None:
        parent = node.parentNode
        holder = getattr(getattr(xacro_module, "_empty_text_node", None), "parentNode", None)
        held = len(holder.childNodes) if holder is not None else 0
        siblings = len(parent.childNodes) if parent is not None else 0
        meter.work(held + 2 * siblings)
        original["remove_previous_comments"](node)
        if parent is not None:  # each comment removed scanned the siblings once more
            meter.work(max(0, siblings + 1 - len(parent.childNodes)) * siblings)

    def parse(inp: Any, filename: str | None = None) -> Any:
        if inp is None and filename is not None:
            _check_include(os.path.join(getattr(xacro_module, "root_dir", "."), filename))
        return original["parse"](inp, filename)

    replacements: dict[str, Callable[..., Any]] = {
        "eval_all": eval_all,
        "eval_text": eval_text,
        "safe_eval": safe_eval,
        "replace_node": replace_node,
        "remove_previous_comments": remove_previous_comments,
        "parse": parse,
    }
    for name, function in replacements.items():
        setattr(xacro_module, name, function)
    try:
        yield
    finally:
        for name, function in original.items():
            setattr(xacro_module, name, function)


def _check_include(path: str) -> None:
    """An included file is a regular file of at most :data:`MAX_XML_BYTES` (the error's
    prefix, added by the caller, names it); a missing one is left to xacro's message."""
    try:
        info = os.stat(path)
    except OSError:
        return
    if not stat.S_ISREG(info.st_mode):
        raise XMLError("not a regular file (xacro includes only files)")
    if info.st_size > MAX_XML_BYTES:
        raise XMLError(
            f"file is {info.st_size / 2**20:.1f} MiB, more than the "
            f"{MAX_XML_BYTES / 2**20:g} MiB limit for XML files"
        )
