"""Opens a ccfr run in ParaView, coloured by the contact distance (a pvpython / pvbatch script).

    xvfb-run -a -s "-screen 0 1280x1024x24" pvbatch --no-mpi scripts/paraview_open.py RUN_DIR \
        [--color distance] [--frame N] [--halted] [--screenshot OUT.png] [--size 960 720] [--state OUT.pvsm]

Reads RUN_DIR/vtk/frames.pvd (written with output.formats including vtu, or `ccfr export RUN_DIR
--format vtu`) with ParaView's PVD reader: every frame, at its time. Shows the surfaces coloured by
the point array --color (default distance: the distance of the closest contact pair a vertex is in,
grey where there is none (NaN); also half_spaces, halted, object_id, velocity). --halted adds the
vertices whose projection halted during the frame as red points. --frame picks the frame shown
(default: the last). --screenshot writes a PNG; --state writes a ParaView state file that the GUI
opens as set up here (`paraview --state=OUT.pvsm`). Prints one summary line, `paraview_open: ...`.

Debian's ParaView renders through GLX only: headless, it needs an X server (xvfb-run), and pvbatch
needs --no-mpi there (with MPI initialised, it cannot open xvfb-run's display); pvpython needs neither
the option nor MPI.
"""
import argparse
import math
import os
import sys
import xml.etree.ElementTree as ET

from paraview import simple as pv

FIELDS = ("distance", "half_spaces", "halted", "object_id", "velocity")


def pvd_frames(pvd):
    """(frame number, time) of every DataSet of the PVD, in file order."""
    frames = []
    for ds in ET.parse(pvd).getroot().iter("DataSet"):
        name = os.path.splitext(os.path.basename(ds.get("file")))[0]  # frame_00042
        frames.append((int(name.rsplit("_", 1)[1]), float(ds.get("timestep"))))
    return frames


def main(argv):
    parser = argparse.ArgumentParser(prog="pvbatch --no-mpi scripts/paraview_open.py",
                                     description="Opens a ccfr run's vtk/frames.pvd in ParaView.")
    parser.add_argument("run_dir")
    parser.add_argument("--color", default="distance", choices=FIELDS, help="point array to colour by")
    parser.add_argument("--frame", type=int, help="frame to show (default: the last written)")
    parser.add_argument("--halted", action="store_true", help="show halted vertices as red points")
    parser.add_argument("--screenshot", metavar="OUT.png")
    parser.add_argument("--size", type=int, nargs=2, default=[960, 720], metavar=("W", "H"))
    parser.add_argument("--state", metavar="OUT.pvsm", help="save a ParaView state file")
    args = parser.parse_args(argv)

    pvd = os.path.abspath(os.path.join(args.run_dir, "vtk", "frames.pvd"))
    if not os.path.exists(pvd):
        sys.exit("paraview_open: %s does not exist: write the run with output.formats including vtu, "
                 "or run `ccfr export %s --format vtu`" % (pvd, args.run_dir))
    try:
        frames = pvd_frames(pvd)
    except (ET.ParseError, TypeError, ValueError, IndexError) as e:
        sys.exit("paraview_open: %s: not a ccfr PVD (%s)" % (pvd, e))
    if not frames:
        sys.exit("paraview_open: %s lists no frames" % pvd)
    if args.frame is None:
        frame, time = frames[-1]
    else:
        match = [t for f, t in frames if f == args.frame]
        if not match:
            sys.exit("paraview_open: %s has no frame %d (it has %d-%d)" % (pvd, args.frame, frames[0][0],
                                                                          frames[-1][0]))
        frame, time = args.frame, match[0]

    reader = pv.PVDReader(registrationName=os.path.basename(os.path.abspath(args.run_dir)), FileName=pvd)
    reader.UpdatePipeline(time)
    info = reader.GetDataInformation()
    names = reader.PointData.keys()
    if args.color not in names:
        sys.exit("paraview_open: %s has no point array '%s' (it has: %s; a run exported from OBJ frames "
                 "has velocity and object_id only)" % (pvd, args.color, ", ".join(names)))

    scene = pv.GetAnimationScene()
    scene.UpdateAnimationUsingDataTimeSteps()
    scene.AnimationTime = time
    view = pv.GetActiveViewOrCreate("RenderView")
    view.ViewSize = args.size
    view.UseColorPaletteForBackground = 0
    view.Background = [1.0, 1.0, 1.0]
    view.OrientationAxesVisibility = 0
    # The surface of tets (their faces) and of triangles alike.
    surface = pv.ExtractSurface(registrationName="surface", Input=reader)
    display = pv.Show(surface, view)
    pv.ColorBy(display, ("POINTS", args.color, "Magnitude") if args.color == "velocity" else ("POINTS", args.color))
    lut = pv.GetColorTransferFunction(args.color)
    lut.ApplyPreset("Viridis (matplotlib)" if args.color == "distance" else "Cool to Warm", True)
    lut.NanColor = [0.75, 0.75, 0.75]  # distance is NaN away from contact
    display.RescaleTransferFunctionToDataRange(False, True)
    display.SetScalarBarVisibility(view, True)
    bar = pv.GetScalarBar(lut, view)
    bar.Title = args.color + (" (m)" if args.color == "distance" else "")
    bar.ComponentTitle = ""
    bar.TitleColor = bar.LabelColor = [0.1, 0.1, 0.1]

    halted = 0
    if args.halted and "halted" in names:
        # One vertex cell per point, then the threshold keeps the halted ones (a threshold on the
        # triangles would keep whole cells, and their unhalted corners).
        points = pv.MaskPoints(registrationName="points", Input=reader, OnRatio=1, RandomSampling=0,
                               MaximumNumberofPoints=2**31 - 1, GenerateVertices=1, SingleVertexPerCell=1)
        keep = pv.Threshold(registrationName="halted vertices", Input=points, Scalars=["POINTS", "halted"],
                            LowerThreshold=0.5, UpperThreshold=1.0)
        keep.UpdatePipeline(time)
        halted = keep.GetDataInformation().GetNumberOfPoints()
        shown = pv.Show(keep, view)
        shown.SetRepresentationType("Points")
        shown.PointSize = 6
        shown.RenderPointsAsSpheres = 1
        shown.AmbientColor = shown.DiffuseColor = [0.9, 0.1, 0.1]
        pv.ColorBy(shown, ("POINTS", None))

    view.CameraViewUp = [0, 1, 0]  # ccfr is y-up
    view.CameraPosition = [1.0, 0.8, 1.6]
    view.CameraFocalPoint = [0, 0, 0]
    view.ResetCamera(False)
    pv.Render(view)

    rng = reader.PointData[args.color].GetRange(-1 if args.color == "velocity" else 0)
    print("paraview_open: %s: %d time steps (times %g-%g), frame %d at time %g: %d points, %d cells; "
          "%s in [%s, %s]; %d halted vertices shown" %
          (pvd, len(reader.TimestepValues), reader.TimestepValues[0], reader.TimestepValues[-1], frame, time,
           info.GetNumberOfPoints(), info.GetNumberOfCells(), args.color,
           "%.6g" % rng[0] if not math.isnan(rng[0]) else "nan", "%.6g" % rng[1] if not math.isnan(rng[1]) else "nan",
           halted))
    if args.screenshot:
        os.makedirs(os.path.dirname(os.path.abspath(args.screenshot)), exist_ok=True)
        pv.SaveScreenshot(args.screenshot, view, ImageResolution=args.size)
        print("paraview_open: wrote %s" % args.screenshot)
    if args.state:
        pv.SaveState(args.state)
        print("paraview_open: wrote %s" % args.state)
    pv.Delete(view)  # left to exit, Debian's pvbatch under Xvfb fails (GLXBadContext) tearing it down
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
