"""Open a ``.pvd`` collection with ParaView's own reader and print what it holds.

Part of the check by hand in docs/exports.md (not run by CI, which has no ParaView)::

    pvpython docs/check_paraview.py check/cloth.pvd
"""

import sys

from paraview.simple import PVDReader

path = sys.argv[1]
reader = PVDReader(FileName=path)
times = list(reader.TimestepValues)
reader.UpdatePipeline(times[-1])
info = reader.GetDataInformation()
print(
    f"{path}: {len(times)} time steps {times[0]:.4g} .. {times[-1]:.4g} s; "
    f"{info.GetNumberOfDataSets()} blocks, {info.GetNumberOfPoints()} points and "
    f"{info.GetNumberOfCells()} cells at the last; "
    f"point arrays {list(reader.PointData.keys())}"
)
