"""One xacro ``${...}`` expression evaluated within the meter's budget, not only counted after.

xacro evaluates an expression with Python's ``eval`` in one go: ``${'x'*10**10}``,
``${[0]*10**10}``, ``${2**10**10}`` or a comprehension over ``python.range(10**9)`` would
allocate gigabytes or run for hours inside that one call, before the meter
(:mod:`harness.models.xacro.meter`) sees its value. :func:`guarded_eval` evaluates the same
expression, with the same checks xacro makes (no ``__`` names, no builtins), after rewriting
its syntax tree so that every step that can make a large value or repeat work asks the meter
first, predicting its cost from its operands:

- ``*`` (repetition), ``+`` (concatenation), ``%`` (formatting), ``**`` and ``<<``: the size
  of the result (its text, as :func:`~harness.models.xacro.meter.XacroMeter.value` counts it)
  is charged before it is made; integers are limited to :data:`MAX_INT_BITS` bits;
- every call: the size of its arguments (a call's work is at most linear in them), callables
  handed to ``map``/``filter``/``sorted``/``min``/``max`` guarded too; string methods that
  widen (``ljust``, ``center``, ``zfill``, ``expandtabs``, ``replace``, ``join``, ``format``)
  charged what they will write, ``round`` digits, ``factorial``/``comb``/``perm`` bounded;
- every item a comprehension draws, every call of a ``lambda`` (C code such as ``sorted`` or
  an object's ``__getitem__`` may call it without end), every operand compared, sliced or
  unpacked, every ``f"{...}"`` field (format widths and precisions checked first); a method
  call charges the size of its object (``[0] * n`` counted ``n`` times is refused);
- ``type()`` with three arguments (a new class, whose methods C code would call) is refused.

``python.vars`` reaches Python's internals (the sandbox escape of issue 31, break 1: why a
recording's xacro is never expanded): code reached that way is not bounded by this guard.

A step over the budget stops the expansion with the meter's one
:class:`~harness.models.files.limits.ModelLimitError` line, before Python does the work. The
value of an expression is unchanged: the rewritten tree computes the same thing.
"""

from __future__ import annotations

import ast
import math
import operator
import re
import string
from collections.abc import Callable, Iterator, Mapping
from typing import Any, NoReturn, Protocol

from harness.models.files.limits import XacroLimits

__all__ = ["HELPERS", "MAX_INT_BITS", "Meter", "guarded_eval", "text_size"]

MAX_INT_BITS = 1 << 16
"""The largest integer an expression may make (65,536 bits, about 20,000 digits: Python
prints no integer longer than 4,300 digits anyway)."""

MAX_FACTORIAL = 5_000
"""The largest ``n`` of ``math.factorial``/``comb``/``perm`` (5000! has about 54,000 bits)."""

HELPERS = ("__hx_bin", "__hx_call", "__hx_charge", "__hx_iter", "__hx_format", "__hx_step")
"""The names the rewritten tree calls (``__`` names: an expression cannot name them)."""

_BINOPS: dict[type[ast.operator], Callable[[Any, Any], Any]] = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.MatMult: operator.matmul,
    ast.Div: operator.truediv,
    ast.Mod: operator.mod,
    ast.Pow: operator.pow,
    ast.LShift: operator.lshift,
    ast.RShift: operator.rshift,
    ast.BitOr: operator.or_,
    ast.BitXor: operator.xor,
    ast.BitAnd: operator.and_,
    ast.FloorDiv: operator.floordiv,
}
_OPS = tuple(_BINOPS.values())
_SIZED = (str, bytes, bytearray, list, tuple, dict, set, frozenset, range)
_ITEM = 2
"""What one item drawn from an iterable is charged (a list entry's share of its text)."""
_SEQUENCES = (str, bytes, bytearray, list, tuple)
_HIGHER_ORDER = (map, filter, sorted, min, max)
_WIDENING = {"ljust", "rjust", "center", "zfill"}
_PERCENT = re.compile(r"%[-#0 +]*(\*|\d+)?(?:\.(\*|\d+))?")
_NUMBER = re.compile(r"\d+")


def _name(node: ast.AST, name: str) -> ast.Name:
    return ast.copy_location(ast.Name(id=name, ctx=ast.Load()), node)


def _call(node: ast.AST, name: str, *args: ast.expr) -> ast.Call:
    return ast.copy_location(ast.Call(func=_name(node, name), args=list(args), keywords=[]), node)


class _Rewrite(ast.NodeTransformer):
    """The expression's tree with each costly step through a helper (see the module
    docstring)."""

    def visit_BinOp(self, node: ast.BinOp) -> ast.AST:
        self.generic_visit(node)
        index = ast.Constant(_OPS.index(_BINOPS[type(node.op)]))
        return _call(node, "__hx_bin", index, node.left, node.right)

    def visit_Call(self, node: ast.Call) -> ast.AST:
        self.generic_visit(node)
        return ast.copy_location(
            ast.Call(
                func=_name(node, "__hx_call"), args=[node.func, *node.args], keywords=node.keywords
            ),
            node,
        )

    def visit_Lambda(self, node: ast.Lambda) -> ast.AST:
        self.generic_visit(node)
        node.body = _call(node.body, "__hx_step", node.body)
        return node

    def visit_comprehension(self, node: ast.comprehension) -> ast.AST:
        self.generic_visit(node)
        node.iter = _call(node.iter, "__hx_iter", node.iter)
        return node

    def visit_Compare(self, node: ast.Compare) -> ast.AST:
        self.generic_visit(node)
        node.left = _call(node.left, "__hx_charge", node.left)
        node.comparators = [_call(c, "__hx_charge", c) for c in node.comparators]
        return node

    def visit_Subscript(self, node: ast.Subscript) -> ast.AST:
        self.generic_visit(node)
        if isinstance(node.slice, ast.Slice):
            node.value = _call(node.value, "__hx_charge", node.value)
        return node

    def visit_Starred(self, node: ast.Starred) -> ast.AST:
        self.generic_visit(node)
        node.value = _call(node.value, "__hx_charge", node.value)
        return node

    def visit_Dict(self, node: ast.Dict) -> ast.AST:
        self.generic_visit(node)
        node.values = [
            _call(v, "__hx_charge", v) if k is None else v
            for k, v in zip(node.keys, node.values, strict=True)
        ]
        return node

    def visit_FormattedValue(self, node: ast.FormattedValue) -> ast.AST:
        self.generic_visit(node)
        spec: ast.expr = node.format_spec if node.format_spec is not None else ast.Constant("")
        value = _call(node, "__hx_format", node.value, ast.Constant(node.conversion), spec)
        return ast.copy_location(ast.FormattedValue(value=value, conversion=-1), node)


class Meter(Protocol):
    """What an evaluation charges: the meter of the expansion it is part of
    (:class:`~harness.models.xacro.meter.Meter`)."""

    @property
    def limits(self) -> XacroLimits: ...

    @property
    def text_bytes(self) -> int: ...

    def text(self, size: int) -> None: ...

    def tick(self) -> None: ...

    def refuse(self, what: str) -> NoReturn: ...


def text_size(value: Any, budget: int) -> int:
    """About the length of ``str(value)``, counted no further than ``budget`` + 1."""
    total = 0
    stack = [value]
    while stack and total <= budget:
        item = stack.pop()
        if isinstance(item, str | bytes):
            total += len(item)
        elif isinstance(item, Mapping):
            total += 4 * len(item) + 2
            if total <= budget:
                stack.extend(item.keys())
                stack.extend(item.values())
        elif isinstance(item, list | tuple | set | frozenset):
            total += 2 * len(item) + 2
            if total <= budget:
                stack.extend(item)
        else:
            total += 8
    return total


class _Guard:
    """The helpers of one evaluation, charging ``meter``."""

    def __init__(self, meter: Meter) -> None:
        self.meter = meter
        self.steps = 0

    def room(self) -> int:
        return max(0, self.meter.limits.text_bytes - self.meter.text_bytes)

    def charge(self, size: int) -> None:
        self.meter.text(size)

    def size(self, value: Any) -> int:
        if isinstance(value, range):  # lazy, but what consumes it makes each item
            return _ITEM * len(value) + 2
        return text_size(value, self.room())

    def int_bits(self, bits: int) -> None:
        if bits > MAX_INT_BITS:
            self.meter.refuse(f"an integer of more than {MAX_INT_BITS} bits")

    def binop(self, index: int, left: Any, right: Any) -> Any:
        op = _OPS[index]
        ints = isinstance(left, int) and isinstance(right, int)
        if op is operator.mul:
            if ints:
                self.int_bits(left.bit_length() + right.bit_length())
            elif isinstance(left, _SEQUENCES) and isinstance(right, int):
                self.charge(self.size(left) * max(0, right))
            elif isinstance(right, _SEQUENCES) and isinstance(left, int):
                self.charge(self.size(right) * max(0, left))
        elif op is operator.pow and ints and right > 0 and abs(left) > 1:
            self.int_bits(left.bit_length() * right)
        elif op is operator.lshift and ints and left:
            self.int_bits(left.bit_length() + max(0, right))
        elif op is operator.add and (isinstance(left, _SIZED) or isinstance(right, _SIZED)):
            self.charge(self.size(left) + self.size(right))
        elif op is operator.mod and isinstance(left, str | bytes):
            self.percent(left, right)
        return op(left, right)

    def percent(self, template: str | bytes, values: Any) -> None:
        text = template if isinstance(template, str) else template.decode("latin-1")
        room = self.room()
        for match in _PERCENT.finditer(text):
            for part in match.groups():
                if part == "*" or (part is not None and int(part) > room):
                    self.meter.refuse("a % format wider than the text left")
        self.charge(len(text) + self.size(values))

    def call(self, function: Any, /, *args: Any, **kwargs: Any) -> Any:
        owner = getattr(function, "__self__", None)
        name = getattr(function, "__name__", "")
        operands = (owner, *args, *kwargs.values())  # a method's work is linear in its object
        self.charge(sum(self.size(a) for a in operands if isinstance(a, _SIZED)))
        if function is type and len(args) > 1:
            self.meter.refuse("a new class (type() with three arguments)")
        if any(function is f for f in _HIGHER_ORDER):
            args = tuple(self.wrap(a) if callable(a) else a for a in args)
            if callable(kwargs.get("key")):
                kwargs["key"] = self.wrap(kwargs["key"])
        if isinstance(owner, str | bytes):
            self.string_method(owner, name, args, kwargs)
        elif function is round and len(args) > 1 and isinstance(args[1], int):
            if abs(args[1]) > 400:  # round(5, -10**9) makes 10**(10**9) first
                self.meter.refuse("round() to more than 400 digits")
        elif (
            owner is math
            and name in ("factorial", "comb", "perm")
            and any(isinstance(a, int) and a > MAX_FACTORIAL for a in args)
        ):
            self.meter.refuse(f"math.{name}() of more than {MAX_FACTORIAL}")
        return function(*args, **kwargs)

    def wrap(self, function: Callable[..., Any]) -> Callable[..., Any]:
        def guarded(*args: Any, **kwargs: Any) -> Any:
            return self.call(function, *args, **kwargs)

        return guarded

    def string_method(self, owner: str | bytes, name: str, args: Any, kwargs: Any) -> None:
        numbers = [a for a in (*args, *kwargs.values()) if isinstance(a, int)]
        if name in _WIDENING or name == "expandtabs":
            width = max(numbers, default=0)
            self.charge(width * (len(owner) if name == "expandtabs" else 1))
        elif name == "replace" and len(args) >= 2:
            old, new = args[0], args[1]
            if isinstance(old, str | bytes) and isinstance(new, str | bytes):
                count = owner.count(old) if old else len(owner) + 1  # type: ignore[arg-type]
                self.charge(count * len(new))
        elif name == "join" and args:
            self.charge(len(owner) * self.count(args[0]))
        elif name in ("format", "format_map") and isinstance(owner, str):
            self.format_spec(owner)

    def count(self, items: Any) -> int:
        try:
            return len(items)
        except TypeError:
            return 0  # an iterator: its items are charged as they are drawn

    def format_spec(self, template: str) -> None:
        room = self.room()
        try:
            fields = list(string.Formatter().parse(template))
        except ValueError:
            return  # Python's own error, from the call
        for _, _, spec, _ in fields:
            if spec and ("{" in spec or any(int(n) > room for n in _NUMBER.findall(spec))):
                self.meter.refuse("a format field wider than the text left")

    def iterate(self, items: Any) -> Iterator[Any]:
        if isinstance(items, _SIZED):  # all at once: a range of 10**9 stops here
            self.charge(_ITEM * len(items))
            for count, item in enumerate(items):
                if count & 0xFFF == 0:
                    self.meter.tick()
                yield item
            return
        for count, item in enumerate(items):
            if count & 0xFFF == 0:
                self.meter.tick()
            self.charge(_ITEM)
            yield item

    def step(self, value: Any) -> Any:
        """One call of a lambda (which C code may call without end): charged, the clock
        checked."""
        self.charge(_ITEM)
        self.steps += 1
        if self.steps & 0xFFF == 0:
            self.meter.tick()
        return value

    def charged(self, value: Any) -> Any:
        if isinstance(value, _SIZED):
            self.charge(self.size(value))
        return value

    def format(self, value: Any, conversion: int, spec: str) -> str:
        if conversion == ord("r"):
            value = repr(value)
        elif conversion == ord("s"):
            value = str(value)
        elif conversion == ord("a"):
            value = ascii(value)
        self.format_spec("{:" + spec + "}")
        self.charge(self.size(value))
        return str(format(value, spec))

    def helpers(self) -> dict[str, Any]:
        return dict(
            zip(
                HELPERS,
                (self.binop, self.call, self.charged, self.iterate, self.format, self.step),
                strict=True,
            )
        )


_TREES: dict[str, Any] = {}


def _compiled(expr: str) -> Any:
    code = _TREES.get(expr)
    if code is None:
        tree = _Rewrite().visit(ast.parse(expr, "<expression>", "eval"))
        code = compile(ast.fix_missing_locations(tree), "<expression>", "eval")
        if len(_TREES) < 10_000:
            _TREES[expr] = code
    return code


def guarded_eval(
    expr: str, symbols: Any, locals_: Any, meter: Meter, error: Callable[..., Exception]
) -> Any:
    """xacro's ``safe_eval(expr, symbols, locals_)`` with every costly step charged to
    ``meter`` first (see the module docstring); ``error`` is xacro's ``XacroException``."""
    text = expr.strip()
    names = compile(text, "<expression>", "eval").co_names  # xacro's check, its error
    invalid = [n for n in names if n.startswith("__")]
    if invalid:
        raise error("Use of invalid name(s): ", ", ".join(invalid))
    shadowed = [name for name in HELPERS if name in symbols]
    if shadowed:
        raise error("Use of invalid name(s): ", ", ".join(shadowed))
    # a property resolved inside evaluates here too: the outer expression's builtins back
    # after it (functions made later read them), xacro's empty ones after the outermost
    previous = dict.get(symbols, "__builtins__", {}) if isinstance(symbols, dict) else {}
    symbols.update(__builtins__=_Guard(meter).helpers())
    try:
        return eval(_compiled(text), symbols, locals_)
    finally:
        symbols.update(__builtins__=previous)
