"""Reading values of a URDF ``<gazebo>``/SDF ``<sensor>`` element: text, numbers, noise.
Errors name the element and the file (``where``)."""

from __future__ import annotations

import math

from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.sensors.errors import SensorConfigError

__all__ = ["element_int", "element_noise", "element_number", "element_text"]


def element_text(el: etree._Element | None, path: str) -> str | None:
    """The stripped text at ``path`` under ``el`` (None when absent)."""
    if el is None:
        return None
    found = el.find(path)
    if found is None or found.text is None:
        return None
    return str(found.text).strip()


def element_number(el: etree._Element | None, path: str, where: str) -> float | None:
    """The finite number at ``path`` (None when absent or empty)."""
    text = element_text(el, path)
    if text is None or text == "":
        return None
    try:
        value = float(text)
    except ValueError:
        raise SensorConfigError(f"{where}: <{path}> is {text!r}, not a number") from None
    if not math.isfinite(value):
        raise SensorConfigError(f"{where}: <{path}> is {text!r}, not a finite number")
    return value


def element_int(el: etree._Element | None, path: str, where: str) -> int | None:
    """The integer at ``path`` (None when absent)."""
    value = element_number(el, path, where)
    if value is None:
        return None
    if value != int(value):
        raise SensorConfigError(f"{where}: <{path}> is {value}, not an integer")
    return int(value)


def element_noise(el: etree._Element | None, where: str) -> dict[str, float]:
    """``noise_mean``/``noise_stddev`` of the first ``<noise>`` under ``el``."""
    if el is None:
        return {}
    noise = el.find(".//noise")
    if noise is None:
        return {}
    out: dict[str, float] = {}
    mean = element_number(noise, "mean", where)
    stddev = element_number(noise, "stddev", where)
    if mean is not None:
        out["noise_mean"] = mean
    if stddev is not None:
        out["noise_stddev"] = stddev
    return out
