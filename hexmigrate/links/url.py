"""What the scheme modules share about link URLs: the error wording and typed parameters.

Every scheme module documents its grammar at its top and names the expected form in each
`LinkUrlError`; this module only keeps that wording and the parameter handling the same
everywhere. Parameters come from a URL's query (or the fault wrapper's fragment) and from keyword
options given to `open_link`, which win, so a program can set what a user would type.
"""

from __future__ import annotations

import ipaddress
import re
from collections.abc import Callable, Mapping
from typing import Any
from urllib.parse import SplitResult, parse_qsl, urlsplit

from hexmigrate.errors import LinkUrlError

Parser = Callable[[str], Any]
_LABEL = re.compile(r"[A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?")
"""One label of a host name (RFC 1123): letters, digits and inner hyphens, 63 at most."""


def url_error(url: str, problem: str, form: str) -> LinkUrlError:
    """A LinkUrlError that says what is wrong with `url` (``expected X, got Y``) and the form
    the scheme takes."""
    return LinkUrlError(f"bad link URL {url!r}: {problem}; the form is {form}")


def parse_parameters(
    url: str,
    text: str,
    parsers: Mapping[str, Parser],
    expected: str,
    options: Mapping[str, object],
) -> dict[str, Any]:
    """The parameters in `text` (``a=1&b=2``) overridden by `options`, each parsed.

    Unknown or repeated names and values a parser refuses raise a LinkUrlError naming the
    parameter, so a typo never falls back silently to a default.
    """
    raw = _split_pairs(url, text, expected)
    raw.update({name: str(value) for name, value in options.items()})
    unknown = sorted(set(raw) - set(parsers))
    if unknown:
        known = ", ".join(parsers)
        raise url_error(url, f"expected parameters among {known}, got {unknown[0]!r}", expected)
    parsed = {}
    for name, value in raw.items():
        try:
            parsed[name] = parsers[name](value)
        except ValueError as error:
            raise url_error(url, f"parameter {name}: {error}", expected) from None
    return parsed


def _split_pairs(url: str, text: str, expected: str) -> dict[str, str]:
    try:
        pairs = parse_qsl(text, keep_blank_values=True, strict_parsing=bool(text))
    except ValueError:
        raise url_error(
            url, f"expected name=value pairs joined by '&', got {text!r}", expected
        ) from None
    raw: dict[str, str] = {}
    for name, value in pairs:
        if name in raw:
            raise url_error(url, f"expected each parameter once, got {name!r} twice", expected)
        raw[name] = value
    return raw


def integer(low: int, high: int | None = None, *, show_hex: bool = False) -> Parser:
    """A parser of whole numbers in [low, high] (no upper bound if None), decimal or 0x-hex.

    `show_hex` words the range in hexadecimal, for values such as CAN ids that are read that way.
    """
    form = "#x" if show_hex else "d"
    bounds = f"{low:{form}} or more" if high is None else f"{low:{form}}..{high:{form}}"

    def parse(text: str) -> int:
        try:
            value = int(text, 0)
        except ValueError:
            raise ValueError(f"expected a whole number, got {text!r}") from None
        if value < low or (high is not None and value > high):
            raise ValueError(f"expected {bounds}, got {value:{form}}")
        return value

    return parse


def real(low: float, high: float) -> Parser:
    """A parser of numbers in [low, high]."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise ValueError(f"expected a number, got {text!r}") from None
        if not low <= value <= high:
            raise ValueError(f"expected {low:g}..{high:g}, got {value:g}")
        return value

    return parse


def choice(*names: str) -> Parser:
    """A parser that accepts one of `names`."""

    def parse(text: str) -> str:
        if text not in names:
            raise ValueError(f"expected one of {', '.join(names)}, got {text!r}")
        return text

    return parse


def network_host(text: str) -> str:
    """A host to listen on or connect to, as the socket calls take it: an IPv4 literal
    (``127.0.0.2``), an IPv6 literal in brackets (``[::1]``, returned without them) or a DNS
    name (``robot-a.local``). Checked here so that a typo fails as a malformed URL at once;
    whether a name resolves, or an address is this machine's, only opening the link can say."""
    if text.startswith("[") and text.endswith("]"):
        try:
            return str(ipaddress.IPv6Address(text[1:-1]))
        except ValueError:
            raise ValueError(f"expected an IPv6 address in brackets, got {text!r}") from None
    if ":" in text:
        raise ValueError(f"expected an IPv6 address in brackets such as [::1], got {text!r}")
    if text.rpartition(".")[2].isdigit():  # a name never ends in a numeric label
        try:
            return str(ipaddress.IPv4Address(text))
        except ValueError:
            raise ValueError(f"expected an IPv4 address such as 127.0.0.1, got {text!r}") from None
    if len(text) > 253 or not all(_LABEL.fullmatch(label) for label in text.split(".")):
        raise ValueError(f"expected an IPv4 or IPv6 address or a host name, got {text!r}")
    return text


def url_host(name: str) -> str:
    """`name` (an address or a host name) as a URL writes it: an IPv6 address in brackets."""
    return f"[{name}]" if ":" in name else name


def host_and_port(
    url: str, host: str, port: str, form: str, lowest_port: int = 1
) -> tuple[str, int]:
    """`host` checked (`network_host`: an IPv6 literal loses its brackets) and `port` as a
    number from `lowest_port` (0: any free one, where a server is to listen) to 65535; a
    LinkUrlError naming which is wrong in `url`, with the scheme's `form`."""
    try:
        checked = network_host(host)
    except ValueError as error:
        raise url_error(url, f"host: {error}", form) from None
    try:
        number: int = integer(lowest_port, 65535)(port)
    except ValueError as error:
        raise url_error(url, f"port: {error}", form) from None
    return checked, number


def split_url(url: str, form: str) -> SplitResult:
    """`url` split as urllib does, a LinkUrlError rather than urllib's bare ValueError for a
    bracketed host that is no IPv6 address (``socket://[::g]:1``, ``tcp-listen://[::1:0``)."""
    try:
        return urlsplit(url)
    except ValueError as error:
        raise url_error(url, f"expected an IPv6 address between brackets: {error}", form) from None
