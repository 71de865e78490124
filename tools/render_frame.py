"""Render one frame of an ek-sim run to PNG, offscreen, with ParaView.

    xvfb-run -a -s "-screen 0 1280x1024x24" pvpython tools/render_frame.py \
        RUN.xmf OUT.png [--field J] [--frame -1] [--size 800 600]

Opens the XDMF that ek-sim writes beside its HDF5 frames (docs/outputs.md)
with ParaView's Xdmf3 reader, colours the mesh by a per-element field
(default J, the volume or area ratio; any field of docs/outputs.md, or
"none"), and saves the frame as a PNG. Two details of ParaView 5.11 that
the README's recipe used to miss:
  - the file is given with a directory (a bare name is joined to the HDF5
    name without a separator and the reader aborts), so the path is made
    absolute here;
  - the pipeline is updated at an explicit time, UpdatePipeline(t): without
    one the reader reports 0 points and the view is blank.
Prints the frame's time, point and cell counts and the field's range;
exits 1 if the frame has no points. Run by ctest (render_frame, through
tests/render_frame_test.py, which checks the PNG is not blank).
"""
import argparse
import os
import sys

try:
    from paraview.simple import (  # noqa: E402  (pvpython provides paraview)
        ColorBy,
        CreateView,
        Delete,
        GetColorTransferFunction,
        Render,
        SaveScreenshot,
        Show,
        Xdmf3ReaderS,
    )
except ImportError as e:
    # Run by python3 instead of pvpython: say how to run it, not a traceback.
    sys.exit(
        f"render_frame.py: {e}: run it with ParaView's pvpython (apt-get install paraview "
        "xvfb), e.g.\n  xvfb-run -a pvpython tools/render_frame.py RUN.xmf OUT.png"
    )


def main(argv):
    p = argparse.ArgumentParser(prog="render_frame.py", description=__doc__.split("\n")[0])
    p.add_argument("xmf")
    p.add_argument("png")
    p.add_argument("--field", default="J", help="per-element field to colour by, or 'none'")
    p.add_argument("--frame", type=int, default=-1, help="frame index (negative: from the end)")
    p.add_argument("--size", type=int, nargs=2, default=[800, 600], metavar=("W", "H"))
    args = p.parse_args(argv)

    reader = Xdmf3ReaderS(FileName=[os.path.abspath(args.xmf)])
    times = list(reader.TimestepValues) if reader.TimestepValues else [0.0]
    if not -len(times) <= args.frame < len(times):
        print(f"render_frame.py: frame {args.frame} of {len(times)}", file=sys.stderr)
        return 2
    t = times[args.frame]
    reader.UpdatePipeline(t)  # an explicit time, or ParaView 5.11 shows 0 points
    info = reader.GetDataInformation()
    npoints, ncells = info.GetNumberOfPoints(), info.GetNumberOfCells()
    print(f"frame {args.frame % len(times)} of {len(times)}: t = {t:g} s, {npoints} points, {ncells} cells")
    if npoints == 0:
        print("render_frame.py: the frame has no points", file=sys.stderr)
        return 1

    view = CreateView("RenderView")
    view.ViewSize = list(args.size)
    view.ViewTime = t
    view.OrientationAxesVisibility = 0
    view.Background = [1.0, 1.0, 1.0]
    try:  # ParaView >= 5.10 draws the background from a palette unless told
        view.UseColorPaletteForBackground = 0
    except AttributeError:
        pass
    display = Show(reader, view)
    if args.field != "none":
        arrays = reader.CellData
        if args.field not in arrays.keys():
            print(f"render_frame.py: no cell field '{args.field}' (have: {', '.join(arrays.keys())})",
                  file=sys.stderr)
            return 2
        lo, hi = arrays[args.field].GetRange()
        print(f"field {args.field}: range [{lo:g}, {hi:g}]")
        ColorBy(display, ("CELLS", args.field))
        display.RescaleTransferFunctionToDataRange(True, False)
        lut = GetColorTransferFunction(args.field)
        lut.ApplyPreset("Viridis (matplotlib)", True)
        display.SetScalarBarVisibility(view, True)
    view.CameraPosition = [1.0, -2.0, 1.2]
    view.CameraFocalPoint = [0.0, 0.0, 0.0]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    view.ResetCamera()
    Render(view)
    SaveScreenshot(args.png, view, ImageResolution=list(args.size))
    print(f"wrote {args.png}")
    # Under Xvfb, a view left for the interpreter's exit dies with an X
    # error (GLXBadContext in glXMakeCurrent) and exit status 1, after the
    # PNG is written; deleted here, it exits cleanly.
    Delete(view)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
