"""Offscreen screenshot of one frame of a ccfr run with VTK (docs/images/interop_vtk.png).

    xvfb-run -a -s "-screen 0 1280x1024x24" /usr/bin/python3 scripts/vtk_screenshot.py \
        RUN_DIR OUT.png FRAME [FIELD]

Reads RUN_DIR/vtk/frame_FRAME.vtu (written with output.formats: [..., vtu]) with VTK's own XML
reader, colours the surface by FIELD (default velocity, as magnitude; any point array of the file:
distance, half_spaces, halted, object_id) with a colour bar, and writes a PNG. Debian's python3-vtk9
renders through GLX only, hence the virtual X server (xvfb-run, package xvfb).
"""
import os
import sys

import vtk


def main(argv):
    if len(argv) < 3:
        sys.exit(__doc__)
    run_dir, out, frame = argv[0], argv[1], int(argv[2])
    field = argv[3] if len(argv) > 3 else "velocity"
    path = os.path.join(run_dir, "vtk", "frame_%05d.vtu" % frame)
    if not os.path.exists(path):
        sys.exit("vtk_screenshot: %s does not exist (run with output.formats including vtu)" % path)
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    arr = grid.GetPointData().GetArray(field)
    if arr is None:
        names = [grid.GetPointData().GetArrayName(i) for i in range(grid.GetPointData().GetNumberOfArrays())]
        sys.exit("vtk_screenshot: %s has no point array '%s' (it has: %s)" % (path, field, ", ".join(names)))
    surface = vtk.vtkDataSetSurfaceFilter()
    surface.SetInputData(grid)
    mapper = vtk.vtkDataSetMapper()
    mapper.SetInputConnection(surface.GetOutputPort())
    mapper.SetScalarModeToUsePointFieldData()
    mapper.SelectColorArray(field)
    lut = vtk.vtkLookupTable()
    lut.SetHueRange(0.667, 0.0)  # blue (low) to red (high)
    if arr.GetNumberOfComponents() > 1:
        lut.SetVectorModeToMagnitude()
        lo, hi = arr.GetRange(-1)
    else:
        lo, hi = arr.GetRange(0)
    lut.Build()
    mapper.SetLookupTable(lut)
    mapper.SetScalarRange(lo, hi if hi > lo else lo + 1.0)
    mapper.ScalarVisibilityOn()
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    bar = vtk.vtkScalarBarActor()
    bar.SetLookupTable(lut)
    bar.SetTitle(field + (" |m/s|" if field == "velocity" else ""))
    bar.SetNumberOfLabels(4)
    bar.GetTitleTextProperty().SetColor(0.1, 0.1, 0.1)
    bar.GetLabelTextProperty().SetColor(0.1, 0.1, 0.1)
    bar.SetWidth(0.08)
    bar.SetHeight(0.6)
    bar.SetPosition(0.9, 0.2)
    renderer = vtk.vtkRenderer()
    renderer.AddActor(actor)
    renderer.AddActor2D(bar)
    renderer.SetBackground(0.85, 0.85, 0.9)
    text = vtk.vtkTextActor()
    text.SetInput("frame %d, colour: %s  (VTK %s, offscreen)" % (frame, field, vtk.vtkVersion.GetVTKVersion()))
    text.GetTextProperty().SetFontSize(16)
    text.GetTextProperty().SetColor(0.1, 0.1, 0.1)
    text.SetDisplayPosition(10, 10)
    renderer.AddActor2D(text)
    camera = renderer.GetActiveCamera()
    camera.SetPosition(1.2, 0.9, 1.6)  # a direction only: ResetCamera frames everything; y is up in ccfr
    camera.SetFocalPoint(0.0, 0.0, 0.0)
    camera.SetViewUp(0, 1, 0)
    renderer.ResetCamera()
    camera.Dolly(1.2)
    renderer.ResetCameraClippingRange()
    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.SetSize(640, 480)
    window.AddRenderer(renderer)
    window.Render()
    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(window)
    grab.Update()
    writer = vtk.vtkPNGWriter()
    writer.SetFileName(out)
    writer.SetInputConnection(grab.GetOutputPort())
    writer.Write()
    print("vtk_screenshot: wrote %s (%d points, %s in [%.4g, %.4g])" % (out, grid.GetNumberOfPoints(), field, lo, hi))


if __name__ == "__main__":
    main(sys.argv[1:])
