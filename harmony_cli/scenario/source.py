"""The one gate every user file passes: a readable regular file within a size limit, UTF-8 text, YAML without
duplicate keys and with alias expansion bounded, every number finite. Each refusal is one ScenarioError line
naming the file (and the line:column or the field)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml

from harmony_cli.scenario.errors import ScenarioError

MAX_BYTES = 1 << 20  # [bytes] a scenario is a few kB; a megabyte is a mistake (or an attack), not a scenario
MAX_NODES = 100_000  # values after expanding YAML aliases: a scenario has a few hundred; a "billion laughs" has 1e9


def read_text(path: Path, what: str = "file", limit: int = MAX_BYTES) -> str:
    """The UTF-8 text of a user file, or one line saying why not (missing, a directory, unreadable, too big,
    binary, not UTF-8)."""
    try:
        if path.is_dir():
            raise ScenarioError(f"{path}: is a directory, not a {what}")
        size = path.stat().st_size
        if size > limit:
            raise ScenarioError(f"{path}: {size} bytes; a {what} is at most {limit} bytes")
        data = path.read_bytes()
    except FileNotFoundError:
        raise ScenarioError(f"{path}: file not found") from None
    except PermissionError:
        raise ScenarioError(f"{path}: not readable (permission denied)") from None
    except OSError as err:
        raise ScenarioError(f"{path}: cannot be read: {err.strerror or err}") from None
    if b"\0" in data:
        raise ScenarioError(f"{path}: binary data (a NUL byte at offset {data.index(0)}), not a {what}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise ScenarioError(
            f"{path}: not UTF-8 text (byte 0x{data[err.start]:02x} at offset {err.start}); save it as UTF-8"
        ) from None


class _StrictLoader(yaml.SafeLoader):
    """PyYAML's safe loader, refusing a key given twice in one mapping (PyYAML keeps the last silently)."""

    def construct_mapping(self, node, deep=False):
        seen: dict = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            if isinstance(key, (list, dict)):
                raise yaml.constructor.ConstructorError(None, None, "a key must be a scalar", key_node.start_mark)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {key!r} given twice (first on line {seen[key] + 1})", key_node.start_mark
                )
            seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


def parse_yaml(text: str, path: Path | str, field: str = "") -> Any:
    """YAML -> Python values; syntax errors with line:column; then `check_values` (`field`: where the text goes,
    for `--set`)."""
    try:
        data = yaml.load(text, Loader=_StrictLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.MarkedYAMLError as err:
        mark = err.problem_mark or err.context_mark
        where = f":{mark.line + 1}:{mark.column + 1}" if mark else ""
        problem = err.problem or err.context or "invalid YAML"
        raise ScenarioError(f"{path}{where}: not valid YAML: {problem}") from None
    except yaml.YAMLError as err:
        raise ScenarioError(f"{path}: not valid YAML: {str(err).splitlines()[0]}") from None
    except RecursionError:
        raise ScenarioError(f"{path}: nested too deeply to be a scenario") from None
    check_values(data, path, field)
    return data


def check_values(data: Any, path: Path | str, where: str = "") -> None:
    """Every number finite; at most MAX_NODES values once aliases are expanded (counted without expanding)."""
    budget = [MAX_NODES]

    def walk(value: Any, field: str) -> None:
        budget[0] -= 1
        if budget[0] < 0:
            raise ScenarioError(
                f"{path}: more than {MAX_NODES} values once YAML aliases are expanded; "
                "a scenario has a few hundred (an alias bomb?)"
            )
        if isinstance(value, float) and not math.isfinite(value):
            raise ScenarioError(f"{path}: {field or '(top level)'}: {value!r}: numbers must be finite")
        if isinstance(value, dict):
            for key, item in value.items():
                walk(item, f"{field}.{key}" if field else str(key))
        elif isinstance(value, list):
            for i, item in enumerate(value):
                walk(item, f"{field}.{i}" if field else str(i))

    try:
        walk(data, where)
    except RecursionError:
        raise ScenarioError(f"{path}: nested too deeply to be a scenario") from None


def load_yaml_file(path: Path, what: str = "scenario") -> Any:
    """A user's YAML file through the gate."""
    return parse_yaml(read_text(path, what), path)
