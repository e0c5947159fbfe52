"""Scenario errors: one line naming the file, the field, the value and the valid choices."""

from __future__ import annotations

from pathlib import Path
from typing import Any, get_args

from pydantic import BaseModel, ValidationError

from harmony_cli.scenario.models import Scenario


class ScenarioError(ValueError):
    """A scenario that cannot be used; the message is one line naming file, field, value and choices."""


def brief(value: Any, limit: int = 100) -> str:
    """repr of a user's value, cut to `limit` characters (a value can be a megabyte of text)."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


def _model_at(loc: tuple, root: type[BaseModel]) -> type[BaseModel] | None:
    """The model at a location such as ('world', 'obstacles', 0, 'motion'), through lists and optionals."""
    model: Any = root
    for part in loc:
        if isinstance(part, int):
            continue
        if not (isinstance(model, type) and issubclass(model, BaseModel)) or part not in model.model_fields:
            return None
        ann = model.model_fields[part].annotation
        models = [
            a
            for a in (ann, *get_args(ann), *(b for a in get_args(ann) for b in get_args(a)))
            if isinstance(a, type) and issubclass(a, BaseModel)
        ]
        model = models[0] if len(set(models)) == 1 else None  # a union of models: no single list of keys
    return model


def one_line(path: Path, err: ValidationError, root: type[BaseModel] = Scenario) -> str:
    """The first validation error of a `root` model as one line: file, field, value and the valid choices."""
    e = err.errors()[0]
    loc = tuple(p for p in e["loc"] if not (isinstance(p, str) and p in ("s_curve", "hold")))
    field = ".".join(str(p) for p in loc) or "(top level)"
    value = e.get("input")
    if e["type"] == "extra_forbidden":
        parent = _model_at(loc[:-1], root)
        choices = (
            ", ".join(field.alias or name for name, field in parent.model_fields.items())
            if parent
            else "see `harmony schema`"
        )
        return f"{path}: {field}: unknown key (value {brief(value)}); valid keys: {choices}"
    if e["type"] == "missing":
        return f"{path}: {field}: required field is missing"
    msg = e["msg"].removeprefix("Value error, ")
    if e["type"] == "union_tag_invalid":
        ctx = e["ctx"]
        return (
            f"{path}: {field}.{ctx['discriminator'].strip(chr(39))}: {brief(ctx['tag'])} is not valid; "
            f"choose one of: {ctx['expected_tags']}"
        )
    if e["type"] == "literal_error":  # a union of literals (qp: auto | daqp | ...) fails once per member
        loc = tuple(p for p in loc if not str(p).startswith("literal["))
        field = ".".join(str(p) for p in loc)
        expected = [
            other["ctx"]["expected"]
            for other in err.errors()
            if other["type"] == "literal_error"
            and tuple(p for p in other["loc"] if not str(p).startswith("literal[")) == loc
        ]
        return f"{path}: {field}: {brief(value)} is not valid; choose one of: {' or '.join(expected)}"
    if isinstance(value, dict):  # a section's own check: its message names the culprit
        return f"{path}: {field}: {msg}"
    return f"{path}: {field}: {brief(value)}: {msg}"
