"""The configuration reference page, generated from the schema and the shipped configuration.

:func:`configuration_reference` walks ``config_schema.yaml`` (JSON Schema, local ``$ref`` resolved)
and lists every key with what the schema allows, whether it is required, its description and the
value ``config/config.yaml`` ships; :func:`write_configuration_reference` writes the page (the docs
build calls it, so the page cannot fall behind the schema).
"""

from __future__ import annotations

import json
from pathlib import Path

import yaml

from nnmstop.atomic import atomic_output

__all__ = ["configuration_reference", "write_configuration_reference"]

_CONSTRAINTS = (
    ("minimum", ">= {}"),
    ("exclusiveMinimum", "> {}"),
    ("maximum", "<= {}"),
    ("exclusiveMaximum", "< {}"),
    ("minLength", "length >= {}"),
    ("minItems", "at least {} items"),
    ("maxItems", "at most {} items"),
    ("pattern", "matches `{}`"),
)


def _resolve(schema: dict, root: dict) -> dict:
    """``schema`` with a local ``$ref`` (``#/a/b``) replaced by its target, keeping sibling keys."""
    while "$ref" in schema:
        ref = schema["$ref"]
        if not ref.startswith("#/"):
            raise ValueError(f"only local $ref are supported in the configuration schema, got {ref!r}")
        target = root
        for part in ref[2:].split("/"):
            target = target[part]
        schema = {**target, **{k: v for k, v in schema.items() if k != "$ref"}}
    return schema


def _allowed(schema: dict, root: dict) -> str:
    """What the schema allows for one key, in words."""
    if "enum" in schema:
        return "one of " + ", ".join(f"`{json.dumps(v)}`" for v in schema["enum"])
    kind = schema.get("type", "any")
    kinds = " or ".join(kind) if isinstance(kind, list) else kind
    parts = [kinds]
    if kind == "array" and "items" in schema:
        items = _resolve(schema["items"], root)
        if items.get("type") != "object":
            parts = [f"array of ({_allowed(items, root)})"]
    parts += [text.format(schema[key]) for key, text in _CONSTRAINTS if key in schema]
    return ", ".join(parts)


def _shipped(config, path: list) -> str:
    value = config
    for part in path:
        if not isinstance(value, dict) or part not in value:
            return ""
        value = value[part]
    if isinstance(value, dict):
        return ""
    return f"`{json.dumps(value)}`"


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _rows(schema: dict, root: dict, config: dict, path: list, required: bool) -> list:
    """Table rows (key, allowed, required, shipped value, description) of ``schema`` and its children."""
    schema = _resolve(schema, root)
    key = ".".join(path)
    rows = []
    if ("oneOf" in schema or "anyOf" in schema) and "properties" not in schema:  # forms, not required-key choices
        return _alternative_rows(schema, root, config, path, required)
    children = schema.get("properties", {})
    item = _resolve(schema.get("items", {}), root) if schema.get("type") == "array" else {}
    if schema.get("type") == "object" or children:
        if len(path) > 1 and (schema.get("description") or not children):
            rows.append((key, "mapping", "yes" if required else "no", "", schema.get("description", "")))
        needed = set(schema.get("required", []))
        for name, child in children.items():
            rows += _rows(child, root, config, [*path, name], name in needed)
        extra = schema.get("additionalProperties")
        if isinstance(extra, dict):
            rows += _rows(extra, root, config, [*path, "<name>"], False)
        return rows
    if item.get("type") == "object":
        rows.append((key, "list of mappings", "yes" if required else "no", "", schema.get("description", "")))
        needed = set(item.get("required", []))
        for name, child in item.get("properties", {}).items():
            rows += _rows(child, root, config, [*path[:-1], f"{path[-1]}[]", name], name in needed)
        return rows
    rows.append(
        (
            key,
            _allowed(schema, root),
            "yes" if required else "no",
            _shipped(config, path),
            schema.get("description", ""),
        )
    )
    return rows


def _alternative_rows(schema: dict, root: dict, config: dict, path: list, required: bool) -> list:
    """Rows of a key that takes one of several forms (``oneOf``/``anyOf``): the key with its plain forms, then
    the keys of its mapping forms."""
    forms = [_resolve(form, root) for form in schema.get("oneOf", schema.get("anyOf", []))]
    mappings = [form for form in forms if form.get("type") == "object"]
    allowed = [_allowed(form, root) for form in forms if form not in mappings] + ["mapping"] * bool(mappings)
    description = schema.get("description") or "; ".join(f["description"] for f in forms if f.get("description"))
    rows = [(".".join(path), " or ".join(allowed), "yes" if required else "no", _shipped(config, path), description)]
    for form in mappings:
        needed = set(form.get("required", []))
        for name, child in form.get("properties", {}).items():
            rows += _rows(child, root, config, [*path, name], name in needed)
    return rows


def configuration_reference(schema: dict, config: dict) -> str:
    """The configuration reference (MyST Markdown) of ``schema``, with the values of ``config``.

    Parameters
    ----------
    schema : dict
        The JSON Schema of the configuration (``src/nnmstop/config_schema.yaml``).
    config : dict
        The shipped configuration (``config/config.yaml``): its values fill the column "shipped".

    Returns
    -------
    str
        One section per top-level key, each a table of its keys (dotted paths; ``<name>`` stands for
        a key the user chooses, ``[]`` for each item of a list).

    Examples
    --------
    >>> schema = {"type": "object", "required": ["model"], "properties": {"model": {"type": "object",
    ...     "properties": {"alpha": {"type": "number", "exclusiveMinimum": 0, "description": "stop stiffness"}}}}}
    >>> print(configuration_reference(schema, {"model": {"alpha": 30.0}}).splitlines()[-1])
    | `model.alpha` | number, > 0 | no | `30.0` | stop stiffness |
    """
    lines = [
        "# Configuration reference",
        "",
        "Generated from `src/nnmstop/config_schema.yaml` at every documentation build",
        "(`nnmstop.docpages.configuration`); the column *shipped* is the value in `config/config.yaml`.",
        "Snakemake validates the configuration against this schema when it loads it: a key that is not",
        "listed here, or a value outside what it allows, stops the run with a message naming the key.",
    ]
    needed = set(schema.get("required", []))
    for section, sub in schema["properties"].items():
        sub = _resolve(sub, schema)
        lines += ["", f"## `{section}`", ""]
        if sub.get("description"):
            lines += [sub["description"][0].upper() + sub["description"][1:] + ".", ""]
        lines.append(f"{'Required' if section in needed else 'Optional'} section.")
        lines += ["", "| key | allowed | required | shipped | description |", "|---|---|---|---|---|"]
        for row in _rows(sub, schema, config, [section], section in needed):
            key, allowed, required, shipped, description = (_cell(c) for c in row)
            lines.append(f"| `{key}` | {allowed} | {required} | {shipped} | {description} |")
    return "\n".join(lines) + "\n"


def write_configuration_reference(schema_file, config_file, output) -> Path:
    """Write :func:`configuration_reference` of two YAML files to ``output`` (only if it changed)."""
    schema = yaml.safe_load(Path(schema_file).read_text())
    config = yaml.safe_load(Path(config_file).read_text())
    output = Path(output)
    text = configuration_reference(schema, config)
    if not output.exists() or output.read_text() != text:
        with atomic_output(output) as partial:
            partial.write_text(text)
    return output
