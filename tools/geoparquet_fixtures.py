"""Writes the GeoParquet test fixtures of crates/citylod-ingest/tests/geoparquet/ from the Lower East Side extract
(../shared/data/nyc-les/les_buildings.geojson, OpenStreetMap, ODbL 1.0) with pyarrow, an independent writer, in the
shape Overture Maps gives its buildings (with the extract's own `building` and `building:part` tags beside, so that
the outlines drawn by their parts are the GeoJSON's). Not run by `make test`: the files it wrote are committed.

    python3 -m venv venv && venv/bin/pip install pyarrow==26.0.1 pyproj==3.7.2
    venv/bin/python tools/geoparquet_fixtures.py ../shared/data/nyc-les/les_buildings.geojson \
        crates/citylod-ingest/tests/geoparquet ../shared/data/nyc-les/les_roads.geojson
"""

import json
import struct
import sys

import pyarrow as pa
import pyarrow.parquet as pq
from pyproj import CRS, Transformer


def wkb_multipolygon(polygons):
    out = [struct.pack("<BI", 1, 6), struct.pack("<I", len(polygons))]
    for rings in polygons:
        out.append(struct.pack("<BII", 1, 3, len(rings)))
        for ring in rings:
            out.append(struct.pack("<I", len(ring)))
            for x, y in ring:
                out.append(struct.pack("<dd", x, y))
    return b"".join(out)


def number(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return None


def whole(v):
    x = number(v)
    return int(x) if x is not None and x == int(x) else None


def main(source, out_dir):
    features = json.load(open(source))["features"]
    rows = []
    for f in features:
        p = f["properties"]
        polygons = f["geometry"]["coordinates"]
        xs = [c[0] for poly in polygons for ring in poly for c in ring]
        ys = [c[1] for poly in polygons for ring in poly for c in ring]
        name = p.get("name")
        rows.append(
            {
                "id": f"{p['osm_type']}/{p['osm_id']}",
                "polygons": polygons,
                "bbox": {"xmin": min(xs), "xmax": max(xs), "ymin": min(ys), "ymax": max(ys)},
                "version": 0,
                "sources": [
                    {
                        "property": "",
                        "dataset": "OpenStreetMap",
                        "record_id": f"{p['osm_type'][0]}{p['osm_id']}@1",
                        "confidence": None,
                    }
                ],
                "names": {"primary": name, "common": [("en", name)] if name else None},
                "class": p.get("building") if p.get("building") not in (None, "yes") else None,
                "building": p.get("building"),
                "building:part": p.get("building:part"),
                "height": number(p.get("height")),
                "num_floors": whole(p.get("building:levels")),
                "min_height": number(p.get("min_height")),
                "min_floor": whole(p.get("building:min_level")),
                "roof_shape": p.get("roof:shape"),
                "roof_height": number(p.get("roof:height")),
            }
        )

    def attributes():
        return {
            "id": pa.array([r["id"] for r in rows], pa.string()),
            "bbox": pa.array(
                [r["bbox"] for r in rows],
                pa.struct([(k, pa.float32()) for k in ("xmin", "xmax", "ymin", "ymax")]),
            ),
            "version": pa.array([r["version"] for r in rows], pa.int32()),
            "sources": pa.array(
                [r["sources"] for r in rows],
                pa.list_(
                    pa.struct(
                        [
                            ("property", pa.string()),
                            ("dataset", pa.string()),
                            ("record_id", pa.string()),
                            ("confidence", pa.float64()),
                        ]
                    )
                ),
            ),
            "names": pa.array(
                [r["names"] for r in rows],
                pa.struct([("primary", pa.string()), ("common", pa.map_(pa.string(), pa.string()))]),
            ),
            "class": pa.array([r["class"] for r in rows], pa.string()),
            "building": pa.array([r["building"] for r in rows], pa.string()),
            "building:part": pa.array([r["building:part"] for r in rows], pa.string()),
            "height": pa.array([r["height"] for r in rows], pa.float64()),
            "num_floors": pa.array([r["num_floors"] for r in rows], pa.int32()),
            "min_height": pa.array([r["min_height"] for r in rows], pa.float64()),
            "min_floor": pa.array([r["min_floor"] for r in rows], pa.int32()),
            "roof_shape": pa.array([r["roof_shape"] for r in rows], pa.string()),
            "roof_height": pa.array([r["roof_height"] for r in rows], pa.float64()),
        }

    # 1. As Overture: WKB in lon/lat (no crs: OGC:CRS84), the bbox covering, ZSTD, row groups of 500.
    columns = attributes()
    columns["geometry"] = pa.array([wkb_multipolygon(r["polygons"]) for r in rows], pa.binary())
    table = pa.table(columns)
    geo = {
        "version": "1.1.0",
        "primary_column": "geometry",
        "columns": {
            "geometry": {
                "encoding": "WKB",
                "geometry_types": ["MultiPolygon"],
                "covering": {
                    "bbox": {
                        "xmin": ["bbox", "xmin"],
                        "ymin": ["bbox", "ymin"],
                        "xmax": ["bbox", "xmax"],
                        "ymax": ["bbox", "ymax"],
                    }
                },
            }
        },
    }
    table = table.replace_schema_metadata({"geo": json.dumps(geo)})
    pq.write_table(table, f"{out_dir}/les_overture.parquet", compression="zstd", row_group_size=500)

    # 2. GeoArrow's native multipolygon encoding ({x, y} structs) in UTM zone 18N (its PROJJSON), Snappy.
    to_utm = Transformer.from_crs("EPSG:4326", "EPSG:32618", always_xy=True)
    point = pa.struct([("x", pa.float64()), ("y", pa.float64())])
    native = [
        [[[dict(zip("xy", to_utm.transform(x, y))) for x, y in ring] for ring in poly] for poly in r["polygons"]]
        for r in rows
    ]
    columns = attributes()
    del columns["bbox"]
    columns["geom"] = pa.array(native, pa.list_(pa.list_(pa.list_(point))))
    table = pa.table(columns)
    geo = {
        "version": "1.1.0",
        "primary_column": "geom",
        "columns": {
            "geom": {
                "encoding": "multipolygon",
                "geometry_types": ["MultiPolygon"],
                "crs": json.loads(CRS.from_epsg(32618).to_json()),
            }
        },
    }
    table = table.replace_schema_metadata({"geo": json.dumps(geo)})
    pq.write_table(table, f"{out_dir}/les_utm_native.parquet", compression="snappy", row_group_size=300)


def ring_area_centroid(ring):
    a = cx = cy = 0.0
    for (x0, y0), (x1, y1) in zip(ring, ring[1:]):
        c = x0 * y1 - x1 * y0
        a += c
        cx += (x0 + x1) * c
        cy += (y0 + y1) * c
    return abs(a) / 2, (cx / (3 * a), cy / (3 * a)) if a else ring[0]


def inside(point, polygons):
    x, y = point
    for rings in polygons:
        crossings = 0
        for ring in rings:
            for (x0, y0), (x1, y1) in zip(ring, ring[1:]):
                if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
                    crossings += 1
        if crossings % 2:
            return True
    return False


def overture_split(source, out_dir):
    """3. As Overture splits them: buildings (without OSM's tags, `has_parts` where parts name them) and building
    parts naming their building by `building_id` (the smallest outline holding the part's centroid), two files."""
    features = json.load(open(source))["features"]
    is_part = lambda f: f["properties"].get("building:part") not in (None, "no")
    outlines = [f for f in features if not is_part(f) and f["properties"].get("building") not in (None, "no")]
    ident = lambda f: f"{f['properties']['osm_type']}/{f['properties']['osm_id']}"
    area = {ident(f): sum(ring_area_centroid(p[0])[0] for p in f["geometry"]["coordinates"]) for f in outlines}
    parent = {}
    for f in features:
        if not is_part(f):
            continue
        _, c = ring_area_centroid(f["geometry"]["coordinates"][0][0])
        holders = [ident(o) for o in outlines if inside(c, o["geometry"]["coordinates"])]
        if holders:
            parent[ident(f)] = min(holders, key=lambda h: area[h])
    with_parts = set(parent.values())
    for name, chosen in (("buildings", lambda f: not is_part(f)), ("parts", is_part)):
        rows = [f for f in features if chosen(f)]
        p = lambda f, k: f["properties"].get(k)
        columns = {
            "id": pa.array([ident(f) for f in rows], pa.string()),
            "geometry": pa.array([wkb_multipolygon(f["geometry"]["coordinates"]) for f in rows], pa.binary()),
            "height": pa.array([number(p(f, "height")) for f in rows], pa.float64()),
            "num_floors": pa.array([whole(p(f, "building:levels")) for f in rows], pa.int32()),
            "min_height": pa.array([number(p(f, "min_height")) for f in rows], pa.float64()),
            "min_floor": pa.array([whole(p(f, "building:min_level")) for f in rows], pa.int32()),
            "roof_shape": pa.array([p(f, "roof:shape") for f in rows], pa.string()),
        }
        if name == "buildings":
            columns["has_parts"] = pa.array([ident(f) in with_parts for f in rows], pa.bool_())
        else:
            columns["building_id"] = pa.array([parent.get(ident(f)) for f in rows], pa.string())
        geo = {"version": "1.1.0", "primary_column": "geometry", "columns": {"geometry": {"encoding": "WKB"}}}
        table = pa.table(columns).replace_schema_metadata({"geo": json.dumps(geo)})
        pq.write_table(table, f"{out_dir}/les_overture_{name}.parquet", compression="zstd")


def streets(source, out_dir):
    """4. The extract's street centre lines in GeoArrow's native line encodings, lon/lat (no `crs`): `linestring` with
    interleaved coordinates (a fixed-size list of two numbers) and `multilinestring` with {x, y} structs."""
    features = json.load(open(source))["features"]
    lines = [f["geometry"]["coordinates"] for f in features]
    names = [f["properties"].get("name") for f in features]
    highway = [f["properties"].get("highway") for f in features]
    interleaved = pa.list_(pa.float64(), 2)
    point = pa.struct([("x", pa.float64()), ("y", pa.float64())])
    for encoding, column in [
        ("linestring", pa.array([[list(p) for p in line] for line in lines], pa.list_(interleaved))),
        (
            "multilinestring",
            pa.array([[[dict(zip("xy", p)) for p in line]] for line in lines], pa.list_(pa.list_(point))),
        ),
    ]:
        table = pa.table({"name": names, "highway": highway, "geometry": column})
        geo = {
            "version": "1.1.0",
            "primary_column": "geometry",
            "columns": {"geometry": {"encoding": encoding, "geometry_types": []}},
        }
        table = table.replace_schema_metadata({"geo": json.dumps(geo)})
        pq.write_table(table, f"{out_dir}/les_roads_{encoding}.parquet", compression="snappy")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
    overture_split(sys.argv[1], sys.argv[2])
    if len(sys.argv) > 3:
        streets(sys.argv[3], sys.argv[2])
