"""Edits of a YAML mapping by key path (rename a key, set, insert or delete one), applied either to its parsed data
or to its text. The text is changed only where an edit falls: each edit replaces the span PyYAML's node marks give
(a key, a value, a whole `key: value` entry), so every comment, blank line, quote and flow or block layout elsewhere
stays byte for byte. PyYAML is harmony's YAML library already; a round-trip parser (ruamel.yaml) would be a new
dependency and re-emits the whole file, which can reflow what an edit never touched."""

from __future__ import annotations

import bisect
import copy
from dataclasses import dataclass
from typing import Any, Literal

import yaml

Kind = Literal["rename", "set", "insert", "delete"]
ORDER: dict[str, int] = {"set": 0, "insert": 1, "delete": 2, "rename": 3}  # paths name the file's keys as written


@dataclass(frozen=True)
class Edit:
    """One change at `path` (the keys from the top, as the file has them): `rename` the key there to `value`; `set`
    its value to `value`; `insert` it with `value` (as its mapping's first key if `first`, else its last);
    `delete` the entry."""

    kind: Kind
    path: tuple[str, ...]
    value: Any = None
    first: bool = False


def apply_to_data(data: dict, edits: list[Edit]) -> dict:
    """A copy of parsed YAML with the edits made (a renamed key keeps its place, an inserted one goes first or last)."""
    data = copy.deepcopy(data)
    for edit in sorted(edits, key=lambda e: ORDER[e.kind]):
        parent = data
        for key in edit.path[:-1]:
            parent = parent[key]
        key = edit.path[-1]
        if edit.kind in ("set", "insert"):
            parent[key] = edit.value
            if edit.first:
                items = [(key, parent.pop(key)), *parent.items()]
                parent.clear()
                parent.update(items)
        elif edit.kind == "delete":
            del parent[key]
        else:
            items = [(edit.value if k == key else k, v) for k, v in parent.items()]
            parent.clear()
            parent.update(items)
    return data


def flow(value: Any) -> str:
    """A value as YAML on one line (a mapping or list in flow style)."""
    text = yaml.safe_dump(value, default_flow_style=True, width=1 << 30, sort_keys=False).strip()
    return text.removesuffix("...").strip()


def content_end(node: yaml.Node) -> int:
    """Where a node's own text ends: a block collection's end mark lies past the comments that follow it."""
    if isinstance(node, yaml.MappingNode) and not node.flow_style and node.value:
        return content_end(node.value[-1][1])
    if isinstance(node, yaml.SequenceNode) and not node.flow_style and node.value:
        return content_end(node.value[-1])
    return node.end_mark.index


def _entry(root: yaml.MappingNode, path: tuple[str, ...]) -> tuple[yaml.MappingNode, int]:
    """The mapping holding `path`'s last key and that key's index in it (-1: not there)."""
    node: yaml.Node = root
    for key in path[:-1]:
        found = [v for k, v in node.value if k.value == key] if isinstance(node, yaml.MappingNode) else []
        if not found:
            raise ValueError(f"{'.'.join(path)}: not found as written (an alias or a merge key?)")
        node = found[0]
    if not isinstance(node, yaml.MappingNode):
        raise ValueError(f"{'.'.join(path[:-1])}: not a mapping as written")
    keys = [k.value for k, _ in node.value]
    return node, keys.index(path[-1]) if path[-1] in keys else -1


def _line_start(text: str, index: int) -> int:
    return text.rfind("\n", 0, index) + 1


def _after_line(text: str, index: int) -> int:
    """The start of the line after the one `index` is on (the end of the text if it is the last); `index` itself
    if it starts a line (where a block scalar's text ends)."""
    if index > 0 and text[index - 1] == "\n":
        return index
    end = text.find("\n", index)
    return len(text) if end < 0 else end + 1


def _comments(text: str, start: int, end: int, ends: list[int]) -> list[str]:
    """The comments on the lines from `start` to `end`: what follows the last YAML token ending on each line."""
    found = []
    line = start
    while line < end:
        stop = text.find("\n", line, end)
        stop = end if stop < 0 else stop
        last = ends[bisect.bisect_right(ends, stop) - 1] if ends and ends[0] <= stop else line
        rest = text[max(last, line) : stop].strip()
        if rest.startswith("#"):
            found.append(rest)
        line = stop + 1
    return found


def _delete(text: str, mapping: yaml.MappingNode, i: int, ends: list[int], newline: str) -> tuple[int, int, str]:
    key, value = mapping.value[i]
    if not mapping.flow_style:  # the entry's lines; a comment on them stays, on a line of its own
        start, end = _line_start(text, key.start_mark.index), _after_line(text, content_end(value))
        indent = " " * key.start_mark.column
        return start, end, "".join(f"{indent}{c}{newline}" for c in _comments(text, start, end, ends))
    if i + 1 < len(mapping.value):  # `key: value, ` up to the next key
        return key.start_mark.index, mapping.value[i + 1][0].start_mark.index, ""
    if i > 0:  # the last entry: from the end of the one before
        return content_end(mapping.value[i - 1][1]), content_end(value), ""
    return key.start_mark.index, content_end(value), ""


def _insert(text: str, mapping: yaml.MappingNode, entry: str, first: bool, newline: str) -> tuple[int, int, str]:
    if mapping.flow_style:
        if not mapping.value:
            at = mapping.end_mark.index - 1  # before the closing brace
            return at, at, entry
        if first:
            at = mapping.value[0][0].start_mark.index
            return at, at, f"{entry}, "
        at = content_end(mapping.value[-1][1])
        return at, at, f", {entry}"
    indent = " " * mapping.value[0][0].start_mark.column
    if first:
        at = _line_start(text, mapping.value[0][0].start_mark.index)
        return at, at, f"{indent}{entry}{newline}"
    at = _after_line(text, content_end(mapping.value[-1][1]))
    return at, at, ("" if at == 0 or text[at - 1] == "\n" else newline) + f"{indent}{entry}{newline}"


def _change(text: str, root: yaml.MappingNode, edit: Edit, ends: list[int], newline: str) -> tuple[int, int, str]:
    """The span of `text` an edit replaces and what replaces it."""
    mapping, i = _entry(root, edit.path)
    if edit.kind == "insert":
        return _insert(text, mapping, f"{edit.path[-1]}: {flow(edit.value)}", edit.first, newline)
    if i < 0:
        raise ValueError(f"{'.'.join(edit.path)}: not found as written")
    key, value = mapping.value[i]
    if edit.kind == "rename":
        return key.start_mark.index, key.end_mark.index, str(edit.value)
    if edit.kind == "delete":
        return _delete(text, mapping, i, ends, newline)
    start, end = value.start_mark.index, content_end(value)
    return start, end, ("" if text[start - 1 : start].isspace() else " ") + flow(edit.value)


def apply_to_text(text: str, edits: list[Edit]) -> str:
    """The YAML text with the edits made in place; ValueError when two of them touch one span (the caller checks
    the result parses to `apply_to_data`'s)."""
    root = yaml.compose(text, Loader=yaml.SafeLoader)
    if not isinstance(root, yaml.MappingNode):
        raise ValueError("not a mapping at the top level")
    newline = "\r\n" if "\r\n" in text else "\n"
    ends = sorted(token.end_mark.index for token in yaml.scan(text, Loader=yaml.SafeLoader))
    changes = sorted((_change(text, root, edit, ends, newline) for edit in edits), reverse=True)
    for (start, _, _), (_, before_end, _) in zip(changes, changes[1:], strict=False):
        if before_end > start:
            raise ValueError("two edits overlap")
    for start, end, new in changes:
        text = text[:start] + new + text[end:]
    return text
