"""Opens a peristat results file with ParaView's own readers (run with pvpython).

    pvpython open_results.py RESULTS.xdmf SUMMARY.json FIELD [FIELD ...]

Checks, with each of ParaView 5.11's three XDMF readers (XDMF Reader, Xdmf3 Reader S and
T), at every load step: as many points as summary.json's particle count, one cell per
particle (the vertex cells without which the default Surface view draws nothing), each
named point array with one tuple per particle, and time values equal to the load factors
of summary.json; contact_state agrees with the step's stick and slip pair counts. The displacement magnitude's range must be non-zero and the same from the
three readers (independent code paths of ParaView reading the same HDF5 datasets).
Exits 1 with every failure listed.
"""
import json
import sys

from paraview import servermanager
from paraview.simple import XDMFReader, Xdmf3ReaderS, Xdmf3ReaderT

xdmf, summary_path, fields = sys.argv[1], sys.argv[2], sys.argv[3:]
with open(summary_path) as f:
    summary = json.load(f)
n = summary["run"]["particles"]
times = [s["load_factor"] for s in summary["steps"]]
failures = []


def check(what, ok):
    if not ok:
        failures.append(what)


ranges = {}
for name, make in [("XDMF Reader", lambda: XDMFReader(FileNames=[xdmf])),
                   ("Xdmf3 Reader S", lambda: Xdmf3ReaderS(FileName=[xdmf])),
                   ("Xdmf3 Reader T", lambda: Xdmf3ReaderT(FileName=[xdmf]))]:
    reader = make()
    got = [float(t) for t in reader.TimestepValues]
    check(f"{name}: times {got} != load factors {times}",
          len(got) == len(times) and all(abs(a - b) <= 1e-12 * max(1.0, abs(b)) for a, b in zip(got, times)))
    for t in times:
        reader.UpdatePipeline(t)
        data = servermanager.Fetch(reader)
        if data.IsA("vtkMultiBlockDataSet"):
            data = data.GetBlock(0)
        cells, points = data.GetNumberOfCells(), data.GetNumberOfPoints()
        check(f"{name} t={t}: {points} points, expected {n}", points == n)
        check(f"{name} t={t}: {cells} cells, expected one per particle ({n})", cells == n)
        arrays = data.GetPointData()
        for field in fields:
            a = arrays.GetArray(field)
            check(f"{name} t={t}: no point array '{field}'", a is not None)
            if a is not None:
                check(f"{name} t={t}: '{field}' has {a.GetNumberOfTuples()} tuples", a.GetNumberOfTuples() == n)
        state = arrays.GetArray("contact_state")
        if state is not None:
            # A particle is in state 2 when one of its pairs slips, >= 1 when one is closed:
            # the step's pair counts in summary.json say whether such particles must exist.
            counts = summary["steps"][times.index(t)]["counts"]
            values = [state.GetValue(i) for i in range(state.GetNumberOfTuples())]
            slipping, closed = sum(v == 2 for v in values), sum(v >= 1 for v in values)
            check(f"{name} t={t}: {slipping} particles slip, summary has {counts['contact_slip']} slipping pairs",
                  (slipping > 0) == (counts["contact_slip"] > 0))
            check(f"{name} t={t}: {closed} particles in closed pairs, summary has "
                  f"{counts['contact_stick'] + counts['contact_slip']} closed pairs",
                  (closed > 0) == (counts["contact_stick"] + counts["contact_slip"] > 0))
            check(f"{name} t={t}: contact_state outside 0..2", all(v in (0, 1, 2) for v in values))
        u = arrays.GetArray("displacement")
        if u is not None:
            ranges.setdefault(t, {})[name] = u.GetRange(-1)  # magnitude range
    print(f"{name}: {len(got)} steps; at the last, {points} points, {cells} cells, arrays "
          f"{sorted(reader.PointData.keys())}")

for t, by_reader in ranges.items():
    values = list(by_reader.values())
    for r in values[1:]:
        check(f"t={t}: |displacement| range differs between readers: {by_reader}",
              abs(r[1] - values[0][1]) <= 1e-12 * max(abs(values[0][1]), 1e-300))
    check(f"t={t}: |displacement| is zero everywhere", values[0][1] > 0.0)

if failures:
    print("FAILED:\n  " + "\n  ".join(failures))
    sys.exit(1)
print("ok")
