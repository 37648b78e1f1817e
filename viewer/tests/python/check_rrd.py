"""What Rerun's own reader (PyPI rerun-sdk) finds in an .rrd file written by `lewis view`.

Prints JSON: the stores (recordings and blueprints), the timelines, and per entity the
rows (static rows included) and the component columns. The Rust test compares the rows
with what it logged; this reader shares no code with the writer beyond Rerun itself.

Usage: python check_rrd.py FILE.rrd
"""

import json
import sys
from collections import defaultdict

from rerun.experimental import RrdReader


def main(path: str) -> None:
    reader = RrdReader(path)
    recordings = reader.recordings()
    blueprints = reader.blueprints()
    rows: dict[str, int] = defaultdict(int)
    static: dict[str, int] = defaultdict(int)
    components: dict[str, set[str]] = defaultdict(set)
    timelines: set[str] = set()
    for chunk in reader.stream():
        entity = chunk.entity_path
        rows[entity] += chunk.num_rows
        if chunk.is_static:
            static[entity] += chunk.num_rows
        timelines.update(chunk.timeline_names)
        for field in chunk.to_record_batch().schema:
            meta = field.metadata or {}
            component = meta.get(b"rerun:component") or meta.get(b"rerun.component")
            if component:
                components[entity].add(component.decode())
    print(
        json.dumps(
            {
                "recordings": [f"{r.application_id}/{r.recording_id}" for r in recordings],
                "blueprints": len(blueprints),
                "timelines": sorted(timelines),
                "rows": dict(sorted(rows.items())),
                "static": dict(sorted(static.items())),
                "components": {e: sorted(c) for e, c in sorted(components.items())},
            },
            indent=1,
        )
    )


if __name__ == "__main__":
    main(sys.argv[1])
