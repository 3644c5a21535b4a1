"""Opens a multifield XDMF with VTK's XDMF reader (ParaView's) and prints, for each time,
its grid's cell count and each cell array's name, tuples, components and largest norm.
Used by tests/dim3/output.rs."""
import sys

from vtkmodules.vtkIOXdmf2 import vtkXdmfReader

reader = vtkXdmfReader()
reader.SetFileName(sys.argv[1])
reader.UpdateInformation()
times = reader.GetOutputInformation(0).Get(reader.GetExecutive().TIME_STEPS())
for t in times:
    reader.UpdateTimeStep(t)
    data = reader.GetOutputDataObject(0)
    it = data.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        grid = it.GetCurrentDataObject()
        if grid.GetNumberOfCells() > 0 and grid.GetCellData().GetNumberOfArrays() > 0:
            print(f"grid {grid.GetNumberOfCells()} cells at t = {t}")
            cells = grid.GetCellData()
            for k in range(cells.GetNumberOfArrays()):
                a = cells.GetArray(k)
                print(a.GetName(), a.GetNumberOfTuples(), a.GetNumberOfComponents(), repr(a.GetMaxNorm()))
        it.GoToNextItem()
