"""Writes the File Geodatabase fixtures of tests/fgdb_input.rs with GDAL's OpenFileGDB driver, an independent writer
of the format, and GDAL's reading of them (`*.reference.json`) for the tests to compare with.

Needs Python 3 with pyogrio (its wheel carries GDAL, used here through ctypes for what pyogrio does not expose:
curves, MultiPatch, deleting rows) and geopandas. Run from this folder:  python3 make_fixtures.py
Not run by `make test`: the fixtures are committed.
"""
import ctypes as C
import glob
import json
import math
import os
import shutil
import zipfile

import geopandas as gpd
import pyogrio

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, '../../../..'))

lib = C.CDLL(glob.glob(os.path.join(os.path.dirname(pyogrio.__file__), '..', 'pyogrio.libs', 'libgdal*.so*'))[0])
lib.GDALAllRegister()
vp = C.c_void_p


class CodedValue(C.Structure):
    _fields_ = [('code', C.c_char_p), ('value', C.c_char_p)]


for name, res, args in [
    ('GDALGetDriverByName', vp, [C.c_char_p]),
    ('GDALCreate', vp, [vp, C.c_char_p, C.c_int, C.c_int, C.c_int, C.c_int, vp]),
    ('GDALOpenEx', vp, [C.c_char_p, C.c_uint, vp, vp, vp]),
    ('GDALClose', None, [vp]),
    ('GDALDatasetCreateLayer', vp, [vp, C.c_char_p, vp, C.c_int, vp]),
    ('GDALDatasetGetLayerByName', vp, [vp, C.c_char_p]),
    ('OSRNewSpatialReference', vp, [C.c_char_p]),
    ('OSRImportFromEPSG', C.c_int, [vp, C.c_int]),
    ('OSRSetAxisMappingStrategy', None, [vp, C.c_int]),
    ('OGR_Fld_Create', vp, [C.c_char_p, C.c_int]),
    ('OGR_Fld_Destroy', None, [vp]),
    ('OGR_L_CreateField', C.c_int, [vp, vp, C.c_int]),
    ('OGR_L_GetLayerDefn', vp, [vp]),
    ('OGR_L_CreateFeature', C.c_int, [vp, vp]),
    ('OGR_L_DeleteFeature', C.c_int, [vp, C.c_int64]),
    ('OGR_FD_GetFieldIndex', C.c_int, [vp, C.c_char_p]),
    ('OGR_F_Create', vp, [vp]),
    ('OGR_F_SetFID', C.c_int, [vp, C.c_int64]),
    ('OGR_F_Destroy', None, [vp]),
    ('OGR_F_SetFieldInteger64', None, [vp, C.c_int, C.c_int64]),
    ('OGR_F_SetFieldDouble', None, [vp, C.c_int, C.c_double]),
    ('OGR_F_SetFieldString', None, [vp, C.c_int, C.c_char_p]),
    ('OGR_F_SetFieldDateTimeEx', None, [vp, C.c_int, C.c_int, C.c_int, C.c_int, C.c_int, C.c_int, C.c_float, C.c_int]),
    ('OGR_F_SetGeometryDirectly', C.c_int, [vp, vp]),
    ('OGR_G_CreateFromWkt', C.c_int, [C.POINTER(C.c_char_p), vp, C.POINTER(vp)]),
    ('CPLGetLastErrorMsg', C.c_char_p, []),
    ('OGR_Fld_SetDomainName', None, [vp, C.c_char_p]),
    ('OGR_CodedFldDomain_Create', vp, [C.c_char_p, C.c_char_p, C.c_int, C.c_int, C.POINTER(CodedValue)]),
    ('GDALDatasetAddFieldDomain', C.c_bool, [vp, vp, C.POINTER(C.c_char_p)]),
]:
    f = getattr(lib, name)
    f.restype, f.argtypes = res, args

OFT = {'int': 0, 'real': 2, 'string': 4, 'date': 9, 'time': 10, 'datetime': 11, 'int64': 12}
WKB = {'polygon': 3, 'multipolygon': 6, 'line': 2, 'none': 100, 'multisurface': 12, 'polyhedralsurface_z': 1015,
       'multipolygon_z': 1006, 'tin_z': 1016}


def options(opts):
    if not opts:
        return None, None
    arr = (C.c_char_p * (len(opts) + 1))(*[o.encode() for o in opts], None)
    return C.cast(arr, vp), arr


def create(path):
    shutil.rmtree(path, ignore_errors=True)
    ds = lib.GDALCreate(lib.GDALGetDriverByName(b'OpenFileGDB'), path.encode(), 0, 0, 0, 0, None)
    assert ds, lib.CPLGetLastErrorMsg()
    return ds


def coded_domain(ds, name, field_type, pairs):
    """A coded value domain: (code, description) pairs."""
    values = (CodedValue * (len(pairs) + 1))(*[CodedValue(c.encode(), v.encode()) for c, v in pairs],
                                              CodedValue(None, None))
    domain = lib.OGR_CodedFldDomain_Create(name.encode(), b'', OFT[field_type], 0, values)
    err = C.c_char_p()
    assert lib.GDALDatasetAddFieldDomain(ds, domain, C.byref(err)), err.value


def layer(ds, name, kind, epsg=None, fields=(), opts=None):
    srs = None
    if epsg:
        srs = lib.OSRNewSpatialReference(None)
        lib.OSRImportFromEPSG(srs, epsg)
        lib.OSRSetAxisMappingStrategy(srs, 0)
    o, keep = options(opts)
    lyr = lib.GDALDatasetCreateLayer(ds, name.encode(), srs, WKB[kind], o)
    assert lyr, lib.CPLGetLastErrorMsg()
    for field in fields:
        fname, ftype = field[0], field[1]
        fld = lib.OGR_Fld_Create(fname.encode(), OFT[ftype])
        if len(field) > 2:
            lib.OGR_Fld_SetDomainName(fld, field[2].encode())
        assert lib.OGR_L_CreateField(lyr, fld, 1) == 0, lib.CPLGetLastErrorMsg()
        lib.OGR_Fld_Destroy(fld)
    return lyr


def add(lyr, wkt, values=None, fid=None):
    f = lib.OGR_F_Create(lib.OGR_L_GetLayerDefn(lyr))
    if fid is not None:
        lib.OGR_F_SetFID(f, fid)
    if wkt:
        s, g = C.c_char_p(wkt.encode()), vp()
        assert lib.OGR_G_CreateFromWkt(C.byref(s), None, C.byref(g)) == 0, wkt
        lib.OGR_F_SetGeometryDirectly(f, g)
    for k, v in (values or {}).items():
        i = lib.OGR_FD_GetFieldIndex(lib.OGR_L_GetLayerDefn(lyr), k.encode())
        if v is None:
            continue
        if isinstance(v, tuple):
            lib.OGR_F_SetFieldDateTimeEx(f, i, *v)
        elif isinstance(v, int):
            lib.OGR_F_SetFieldInteger64(f, i, v)
        elif isinstance(v, float):
            lib.OGR_F_SetFieldDouble(f, i, v)
        else:
            lib.OGR_F_SetFieldString(f, i, v.encode())
    assert lib.OGR_L_CreateFeature(lyr, f) == 0, lib.CPLGetLastErrorMsg()
    lib.OGR_F_Destroy(f)


def square(x, y, s, hole=False):
    outer = f'({x} {y}, {x + s} {y}, {x + s} {y + s}, {x} {y + s}, {x} {y})'
    if not hole:
        return f'POLYGON ({outer})'
    q = s / 4
    inner = f'({x + q} {y + q}, {x + 3 * q} {y + q}, {x + 3 * q} {y + 3 * q}, {x + q} {y + 3 * q}, {x + q} {y + q})'
    return f'POLYGON ({outer}, {inner})'


def box_z(x, y, s, h, base=0, kind='POLYHEDRALSURFACE Z'):
    """A closed box from `base` up to `h` as a PolyhedralSurface Z (GDAL writes it as a MultiPatch), or another
    collection of polygons with z."""
    c = [(x, y), (x + s, y), (x + s, y + s), (x, y + s)]
    faces = ['((' + ', '.join(f'{a} {b} {base}' for a, b in c[::-1] + [c[-1]]) + '))',
             '((' + ', '.join(f'{a} {b} {h}' for a, b in c + [c[0]]) + '))']
    for i in range(4):
        (a, b), (d, e) = c[i], c[(i + 1) % 4]
        faces.append(f'(({a} {b} {base}, {d} {e} {base}, {d} {e} {h}, {a} {b} {h}, {a} {b} {base}))')
    return kind + ' (' + ', '.join(faces) + ')'


def kinds():
    """Several feature classes in UTM 18N: polygons with deleted rows (a whole block of 1,024 among them), curves,
    MultiPatch models, lines and a table without geometry."""
    path = os.path.join(HERE, 'kinds.gdb')
    ds = create(path)
    blocks = layer(ds, 'blocks', 'multipolygon', 32618,
                   [('storeys', 'int'), ('name', 'string'), ('height', 'real'), ('built', 'date'),
                    ('surveyed', 'datetime')])
    x0, y0 = 583000.0, 4507000.0
    for i in range(3000):
        x, y = x0 + (i % 60) * 20.0, y0 + (i // 60) * 20.0
        add(blocks, square(x, y, 12.5, hole=(i % 7 == 0)),
            {'storeys': i % 9 + 1, 'name': f'Block {i + 1} – Straße' if i % 5 else None, 'height': 3.25 * (i % 9 + 1),
             'built': (1900 + i % 120, i % 12 + 1, i % 28 + 1, 0, 0, 0.0, 0),
             'surveyed': (2024, 5, 17, 13, 45, 30.5, 0) if i % 3 == 0 else None})
    round_ = layer(ds, 'round', 'multisurface', 32618, [('kind', 'string')])
    cx, cy = x0 + 2000, y0
    add(round_, f'CURVEPOLYGON (CIRCULARSTRING ({cx - 10} {cy}, {cx} {cy + 10}, {cx + 10} {cy}, {cx} {cy - 10}, '
                f'{cx - 10} {cy}))', {'kind': 'tower'})
    add(round_, f'CURVEPOLYGON (COMPOUNDCURVE (({cx + 50} {cy}, {cx + 80} {cy}), CIRCULARSTRING ({cx + 80} {cy}, '
                f'{cx + 95} {cy + 15}, {cx + 80} {cy + 30}), ({cx + 80} {cy + 30}, {cx + 50} {cy + 30}, {cx + 50} {cy})))',
        {'kind': 'apse'})
    add(round_, 'MULTISURFACE (' + square(cx + 200, cy, 30, hole=True)[len('POLYGON '):] + ')', {'kind': 'plain'})
    # Full circles: a round building with a round courtyard, and one with a square courtyard.
    ox = cx + 400
    add(round_, f'CURVEPOLYGON (CIRCULARSTRING ({ox - 15} {cy}, {ox + 15} {cy}, {ox - 15} {cy}), '
                f'CIRCULARSTRING ({ox - 5} {cy}, {ox + 5} {cy}, {ox - 5} {cy}))', {'kind': 'round courtyard'})
    ox = cx + 500
    add(round_, f'CURVEPOLYGON (CIRCULARSTRING ({ox - 15} {cy}, {ox + 15} {cy}, {ox - 15} {cy}), '
                f'({ox - 5} {cy - 5}, {ox + 5} {cy - 5}, {ox + 5} {cy + 5}, {ox - 5} {cy + 5}, {ox - 5} {cy - 5}))',
        {'kind': 'square courtyard'})
    models = layer(ds, 'models', 'polyhedralsurface_z', 32618, [('name', 'string')])
    add(models, box_z(x0 + 3000, y0, 10, 21.0), {'name': 'box'})
    add(models, box_z(x0 + 3100, y0, 16, 45.5), {'name': 'tall box'})
    add(models, f'TIN Z ((({x0 + 3200} {y0} 0, {x0 + 3210} {y0} 0, {x0 + 3205} {y0 + 8} 12, {x0 + 3200} {y0} 0)), '
                f'(({x0 + 3210} {y0} 0, {x0 + 3210} {y0 + 8} 0, {x0 + 3205} {y0 + 8} 12, {x0 + 3210} {y0} 0)))',
        {'name': 'tent'})
    # Models written as polygons with z in a MultiPatch layer (GDAL's CREATE_MULTIPATCH=YES): a box standing at z 5.
    walls = layer(ds, 'walls', 'multipolygon_z', 32618, [('name', 'string')], opts=['CREATE_MULTIPATCH=YES'])
    wx, wy = x0 + 3300, y0
    add(walls, box_z(wx, wy, 10, 17, base=5, kind='MULTIPOLYGON Z'), {'name': 'raised box'})
    roads = layer(ds, 'roads', 'line', 32618, [('name', 'string')])
    add(roads, f'LINESTRING ({x0} {y0 - 10}, {x0 + 1200} {y0 - 10})', {'name': 'Main Street'})
    table = layer(ds, 'owners', 'none', None, [('owner', 'string')])
    add(table, None, {'owner': 'city'})
    lib.GDALClose(ds)
    # Rows deleted: a whole block of 1,024 OBJECTIDs (the row index then leaves it out) and two single rows.
    ds = lib.GDALOpenEx(path.encode(), 0x04 | 0x01, None, None, None)
    lyr = lib.GDALDatasetGetLayerByName(ds, b'blocks')
    for oid in list(range(1025, 2049)) + [7, 2999]:
        assert lib.OGR_L_DeleteFeature(lyr, oid) == 0, oid
    lib.GDALClose(ds)


def pro32():
    """ArcGIS Pro 3.2's table layout (64-bit OBJECTIDs, big integers, dates and times of their own)."""
    path = os.path.join(HERE, 'pro32.gdb')
    ds = create(path)
    lyr = layer(ds, 'buildings', 'multipolygon', 2263,
                [('bin', 'int64'), ('opened', 'date'), ('closes', 'time'), ('stamp', 'datetime'), ('height_ft', 'real')],
                opts=['TARGET_ARCGIS_VERSION=ARCGIS_PRO_3_2_OR_LATER'])
    for i in range(5):
        x, y = 987000.0 + 100 * i, 201000.0
        add(lyr, square(x, y, 60), {'bin': 1_000_000_000_000 + i, 'opened': (2001 + i, 2, 3, 0, 0, 0.0, 0),
                                    'closes': (0, 0, 0, 18, 30, 15.0, 0), 'stamp': (2020, 1, 2, 3, 4, 5.0, 100),
                                    'height_ft': 100.0 + i})
    lib.GDALClose(ds)


def sparse():
    """OBJECTIDs with gaps of whole blocks of 1,024 (1-100, 2049-2100, 5000, 70000): the row index then stores only
    the blocks that hold rows, and a bitmap of them."""
    path = os.path.join(HERE, 'sparse.gdb')
    ds = create(path)
    lyr = layer(ds, 'footprints', 'polygon', 32618, [('height', 'real')])
    for oid in list(range(1, 101)) + list(range(2049, 2101)) + [5000, 70000]:
        x, y = 583000.0 + (oid % 50) * 20, 4507000.0 + (oid // 50) * 20
        add(lyr, square(x, y, 10), {'height': float(oid % 40 + 3)}, fid=oid)
    lib.GDALClose(ds)


def datasets():
    """Two feature classes in a feature dataset (`Buildings`), one at the top, in State Plane feet."""
    path = os.path.join(HERE, 'datasets.gdb')
    ds = create(path)
    for name, dataset in [('Footprints', 'Buildings'), ('Towers', 'Buildings'), ('Parcels', None)]:
        opts = [f'FEATURE_DATASET={dataset}'] if dataset else None
        lyr = layer(ds, name, 'multipolygon', 2263, [('height', 'real')], opts=opts)
        add(lyr, square(987000.0, 201000.0, 60), {'height': 12.0})
    lib.GDALClose(ds)


def domains():
    """Fields with coded value domains, as ArcGIS users keep building use and status: codes stored, descriptions in
    the geodatabase's item table."""
    path = os.path.join(HERE, 'domains.gdb')
    ds = create(path)
    coded_domain(ds, 'BuildingUse', 'int', [('1', 'Residential'), ('2', 'Commercial'), ('3', 'Industrial')])
    coded_domain(ds, 'Status', 'string', [('A', 'Active'), ('D', 'Demolished')])
    lyr = layer(ds, 'buildings', 'multipolygon', 32618,
                [('use', 'int', 'BuildingUse'), ('status', 'string', 'Status'), ('height', 'real')])
    for k, (use, status) in enumerate([(1, 'A'), (2, 'D'), (3, 'A'), (None, None), (9, 'X')]):
        add(lyr, square(583000.0 + 20 * k, 4507000.0, 10), {'use': use, 'status': status, 'height': 9.0})
    lib.GDALClose(ds)


def no_crs():
    path = os.path.join(HERE, 'no-crs.gdb')
    ds = create(path)
    lyr = layer(ds, 'footprints', 'polygon', None, [('h', 'real')])
    add(lyr, square(100, 100, 10), {'h': 9.0})
    lib.GDALClose(ds)


def nyc():
    df = gpd.read_file(os.path.join(REPO, 'examples/nyc-les/les_buildings.geojson')).to_crs('EPSG:2263')
    path = os.path.join(HERE, 'nyc-les-2263.gdb')
    shutil.rmtree(path, ignore_errors=True)
    df.to_file(path, driver='OpenFileGDB', layer='buildings')


def roads():
    """The Lower East Side road lines, as a city keeps its street centre lines: State Plane feet, a File Geodatabase."""
    df = gpd.read_file(os.path.join(REPO, 'examples/nyc-les/les_roads.geojson')).to_crs('EPSG:2263')
    path = os.path.join(HERE, 'nyc-les-roads-2263.gdb')
    shutil.rmtree(path, ignore_errors=True)
    df.to_file(path, driver='OpenFileGDB', layer='roads')


def reference(gdb, name):
    """GDAL's reading of a feature class: OBJECTID, attributes as GDAL's text, polygons linearized by GDAL in lon/lat
    (MultiPatch models as their faces)."""
    df = pyogrio.read_dataframe(os.path.join(HERE, gdb), layer=name, fid_as_index=True)
    if df.crs is not None:
        df = df.to_crs('EPSG:4326')
    out = []
    for fid, row in df.iterrows():
        g = row.geometry
        polys = []
        if g is not None and not g.is_empty:
            for p in getattr(g, 'geoms', [g]):
                if p.geom_type != 'Polygon':
                    continue
                polys.append([[list(c) for c in r.coords[:-1]] for r in [p.exterior, *p.interiors]])
        attrs = {}
        for k, v in row.items():
            if k == 'geometry':
                continue
            if v is None or (isinstance(v, float) and math.isnan(v)):
                attrs[k] = None
            elif hasattr(v, 'isoformat'):
                attrs[k] = v.isoformat()
            else:
                attrs[k] = v.item() if hasattr(v, 'item') else v
        out.append({'objectid': int(fid), 'attributes': attrs, 'polygons': polys})
    with open(os.path.join(HERE, f'{gdb[:-4]}.{name}.reference.json'), 'w') as f:
        json.dump(out, f, separators=(',', ':'), default=str)


def zips():
    """Geodatabases zipped by Python's zipfile (an independent writer of ZIP): as downloaded (deflated, the folder at
    the top), stored in a sub-folder with ZIP64 records, two geodatabases in one archive, and none."""
    def add_dir(z, folder, prefix):
        for f in sorted(os.listdir(os.path.join(HERE, folder))):
            z.write(os.path.join(HERE, folder, f), prefix + f)
    with zipfile.ZipFile(os.path.join(HERE, 'nyc-les-2263.gdb.zip'), 'w', zipfile.ZIP_DEFLATED) as z:
        add_dir(z, 'nyc-les-2263.gdb', 'nyc-les-2263.gdb/')
    with zipfile.ZipFile(os.path.join(HERE, 'nested-zip64.zip'), 'w', zipfile.ZIP_STORED, allowZip64=True) as z:
        for f in sorted(os.listdir(os.path.join(HERE, 'no-crs.gdb'))):
            with open(os.path.join(HERE, 'no-crs.gdb', f), 'rb') as src, \
                    z.open('download/data/Footprints.gdb/' + f, 'w', force_zip64=True) as dst:
                dst.write(src.read())
        z.writestr('download/readme.txt', 'made-up footprints')
    with zipfile.ZipFile(os.path.join(HERE, 'two.zip'), 'w', zipfile.ZIP_DEFLATED) as z:
        add_dir(z, 'no-crs.gdb', 'a.gdb/')
        add_dir(z, 'no-crs.gdb', 'b.gdb/')
    with zipfile.ZipFile(os.path.join(HERE, 'none.zip'), 'w', zipfile.ZIP_DEFLATED) as z:
        z.writestr('buildings.geojson', '{"type": "FeatureCollection", "features": []}')


if __name__ == '__main__':
    nyc()
    roads()
    kinds()
    pro32()
    no_crs()
    sparse()
    datasets()
    domains()
    for gdb, name in [('sparse.gdb', 'footprints'), ('kinds.gdb', 'blocks'), ('kinds.gdb', 'round'),
                      ('pro32.gdb', 'buildings')]:
        reference(gdb, name)
    zips()
    print('written')
