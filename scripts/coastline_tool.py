"""Developer tool (not used at run time): make ``src/urc/web/static/world-110m.geojson``.

Source: Natural Earth 1:110m land (public domain) as TopoJSON, from the npm package
``world-atlas@2`` (``npm pack world-atlas@2.0.2``; file ``package/land-110m.json``).
The arcs are decoded (delta + quantisation), stitched into rings and rounded to 0.1 deg,
which keeps the shipped file well under 100 kB while the outline still reads at a glance.

Usage: python scripts/coastline_tool.py path/to/land-110m.json [out.geojson]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

DECIMALS = 1


def decode_arcs(topo: dict) -> list[list[tuple[float, float]]]:
    (sx, sy), (tx, ty) = topo["transform"]["scale"], topo["transform"]["translate"]
    arcs = []
    for arc in topo["arcs"]:
        x = y = 0
        pts = []
        for dx, dy in arc:
            x, y = x + dx, y + dy
            pts.append((x * sx + tx, y * sy + ty))
        arcs.append(pts)
    return arcs


def ring(arcs: list[list[tuple[float, float]]], indexes: list[int]) -> list[list[float]]:
    out: list[tuple[float, float]] = []
    for i in indexes:
        pts = arcs[i] if i >= 0 else arcs[~i][::-1]
        out.extend(pts if not out else pts[1:])  # arcs share their end points
    rounded: list[list[float]] = []
    for lon, lat in out:
        p = [round(lon, DECIMALS), round(lat, DECIMALS)]
        if not rounded or p != rounded[-1]:
            rounded.append(p)
    if rounded and rounded[0] != rounded[-1]:
        rounded.append(rounded[0])
    return rounded


def convert(topo: dict) -> dict:
    arcs = decode_arcs(topo)
    polygons = []
    for geom in topo["objects"]["land"]["geometries"]:
        polys = geom["arcs"] if geom["type"] == "MultiPolygon" else [geom["arcs"]]
        for poly in polys:
            rings = [r for r in (ring(arcs, idx) for idx in poly) if len(r) >= 4]
            if rings:
                polygons.append(rings)
    return {"type": "FeatureCollection", "features": [{
        "type": "Feature",
        "properties": {"name": "land", "source": "Natural Earth 1:110m land (public domain), "
                       "via world-atlas 2.0.2, rounded to 0.1 deg"},
        "geometry": {"type": "MultiPolygon", "coordinates": polygons}}]}


def main(argv: list[str]) -> None:
    src = Path(argv[1])
    out = Path(argv[2]) if len(argv) > 2 else (Path(__file__).resolve().parents[1] / "src" / "urc" / "web" / "static"
                                                   / "world-110m.geojson")
    out.write_text(json.dumps(convert(json.loads(src.read_text())), separators=(",", ":")))
    print(f"{out}: {out.stat().st_size} bytes")


if __name__ == "__main__":
    main(sys.argv)
