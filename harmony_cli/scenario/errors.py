"""Scenario errors: one line naming the file, the field, the value and the valid choices."""

from __future__ import annotations

from pathlib import Path
from typing import Any, get_args

from pydantic import BaseModel, ValidationError

from harmony_cli.scenario.models import Scenario


class ScenarioError(ValueError):
    """A scenario that cannot be used; the message is one line naming file, field, value and choices."""


def _model_at(loc: tuple) -> type[BaseModel] | None:
    """The model at a location such as ('world', 'obstacles', 0, 'motion'), through lists and optionals."""
    model: Any = Scenario
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


def one_line(path: Path, err: ValidationError) -> str:
    """The first validation error as one line: file, field, value and the valid choices."""
    e = err.errors()[0]
    loc = tuple(p for p in e["loc"] if not (isinstance(p, str) and p in ("s_curve", "hold")))
    field = ".".join(str(p) for p in loc) or "(top level)"
    value = e.get("input")
    if e["type"] == "extra_forbidden":
        parent = _model_at(loc[:-1])
        choices = ", ".join(parent.model_fields) if parent else "see `harmony schema`"
        return f"{path}: {field}: unknown key (value {value!r}); valid keys: {choices}"
    if e["type"] == "missing":
        return f"{path}: {field}: required field is missing"
    msg = e["msg"].removeprefix("Value error, ")
    if e["type"] == "union_tag_invalid":
        ctx = e["ctx"]
        return (
            f"{path}: {field}.{ctx['discriminator'].strip(chr(39))}: {ctx['tag']!r} is not valid; "
            f"choose one of: {ctx['expected_tags']}"
        )
    if e["type"] == "literal_error":
        return f"{path}: {field}: {value!r} is not valid; choose one of: {e['ctx']['expected']}"
    return f"{path}: {field}: {value!r}: {msg}"
