"""What Rerun's own reader (PyPI rerun-sdk) finds in an .rrd file written by `lewis view`.

Prints JSON: the stores (recordings and blueprints), the timelines, per entity the rows
(static rows included) and the component columns, the texts of the text logs and the
values of the state lanes in row order (time order within each entity, as written), and
the blueprint's views (name, class, origin, contents). The Rust test compares them with
what it logged; this reader shares no code with the writer beyond Rerun itself.

Usage: python check_rrd.py FILE.rrd
"""

import json
import sys
from collections import defaultdict

from rerun.experimental import RrdReader


def component_columns(chunk):
    """(component name, values per row) for each component column of a chunk."""
    batch = chunk.to_record_batch()
    for field, column in zip(batch.schema, batch.columns):
        meta = field.metadata or {}
        component = meta.get(b"rerun:component") or meta.get(b"rerun.component")
        if component:
            yield component.decode(), column.to_pylist()


def first(value):
    """The first item of a row's list (components are lists per row), or the value."""
    if isinstance(value, list):
        return value[0] if value else None
    return value


def blueprint_views(reader):
    """The views of the first blueprint: name, class, origin and contents queries."""
    stores = reader.blueprints()
    if not stores:
        return []
    views = defaultdict(dict)
    for chunk in reader.stream(store=stores[0]):
        path = chunk.entity_path.strip("/")
        parts = path.split("/")
        if len(parts) < 2 or parts[0] != "view":
            continue
        view = views[parts[1]]
        for component, rows in component_columns(chunk):
            value = rows[-1] if rows else None
            if component == "ViewBlueprint:display_name":
                view["name"] = first(value)
            elif component == "ViewBlueprint:class_identifier":
                view["class"] = first(value)
            elif component == "ViewBlueprint:space_origin":
                view["origin"] = first(value)
            elif component == "ViewContents:query":
                view["contents"] = value or []
    return [
        {
            "name": v.get("name", ""),
            "class": v.get("class", ""),
            "origin": v.get("origin", ""),
            "contents": v.get("contents", []),
        }
        for _, v in sorted(views.items())
    ]


def main(path: str) -> None:
    reader = RrdReader(path)
    recordings = reader.recordings()
    blueprints = reader.blueprints()
    rows: dict[str, int] = defaultdict(int)
    static: dict[str, int] = defaultdict(int)
    components: dict[str, set[str]] = defaultdict(set)
    texts: dict[str, list[str]] = defaultdict(list)
    states: dict[str, list[str]] = defaultdict(list)
    timelines: set[str] = set()
    for chunk in reader.stream():
        entity = chunk.entity_path
        rows[entity] += chunk.num_rows
        if chunk.is_static:
            static[entity] += chunk.num_rows
        timelines.update(chunk.timeline_names)
        for component, values in component_columns(chunk):
            components[entity].add(component)
            if component == "TextLog:text":
                texts[entity].extend(first(v) for v in values)
            elif component.startswith("StateChange:"):
                states[entity].extend(str(first(v)) for v in values)
    print(
        json.dumps(
            {
                "recordings": [f"{r.application_id}/{r.recording_id}" for r in recordings],
                "blueprints": len(blueprints),
                "timelines": sorted(timelines),
                "rows": dict(sorted(rows.items())),
                "static": dict(sorted(static.items())),
                "components": {e: sorted(c) for e, c in sorted(components.items())},
                "texts": dict(sorted(texts.items())),
                "states": dict(sorted(states.items())),
                "views": blueprint_views(reader),
            },
            indent=1,
        )
    )


if __name__ == "__main__":
    main(sys.argv[1])
