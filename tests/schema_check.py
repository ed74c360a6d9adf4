"""A validator for the part of JSON Schema (2020-12) that
elastica_petsc/schema/output.schema.json uses: type, required, properties,
items, enum, const, allOf, if/then, local $ref, propertyNames.  A keyword it
does not know is an error, so the schema cannot silently use more."""
from __future__ import annotations

KNOWN = {"$schema", "$id", "title", "description", "$defs", "type", "required", "properties",
         "items", "enum", "const", "allOf", "if", "then", "$ref", "propertyNames"}
TYPES = {"object": dict, "array": list, "string": str, "boolean": bool, "null": type(None)}


def _is(value, name: str) -> bool:
    if name == "integer":
        return isinstance(value, int) and not isinstance(value, bool)
    if name == "number":
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    return isinstance(value, TYPES[name])


def errors(value, schema: dict, root: dict, where: str = "$") -> list[str]:
    """Every way ``value`` fails ``schema`` (empty: valid)."""
    unknown = set(schema) - KNOWN
    if unknown:
        return [f"{where}: schema keyword(s) {sorted(unknown)} not supported"]
    out = []
    if "$ref" in schema:
        target = root
        for part in schema["$ref"].lstrip("#/").split("/"):
            target = target[part]
        out += errors(value, target, root, where)
    if "type" in schema:
        names = schema["type"] if isinstance(schema["type"], list) else [schema["type"]]
        if not any(_is(value, n) for n in names):
            return out + [f"{where}: {type(value).__name__} is not {schema['type']}"]
    if "const" in schema and value != schema["const"]:
        out.append(f"{where}: {value!r} is not {schema['const']!r}")
    if "enum" in schema and value not in schema["enum"]:
        out.append(f"{where}: {value!r} is not one of {schema['enum']}")
    if isinstance(value, dict):
        out += [f"{where}: missing {k!r}" for k in schema.get("required", ()) if k not in value]
        for k, sub in schema.get("properties", {}).items():
            if k in value:
                out += errors(value[k], sub, root, f"{where}.{k}")
        if "propertyNames" in schema:
            for k in value:
                out += errors(k, schema["propertyNames"], root, f"{where} key {k!r}")
    if isinstance(value, list) and "items" in schema:
        for i, item in enumerate(value):
            out += errors(item, schema["items"], root, f"{where}[{i}]")
    for sub in schema.get("allOf", ()):
        out += errors(value, sub, root, where)
    if "if" in schema and not errors(value, schema["if"], root, where):
        out += errors(value, schema.get("then", {}), root, where)
    return out
