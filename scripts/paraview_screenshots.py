"""pvpython side of scripts/paraview-screenshots (see there)."""
import os
import sys

from paraview.simple import ColorBy, Glyph, GetActiveViewOrCreate, Hide, OpenDataFile, ResetCamera, SaveScreenshot, Show

# Absolute paths: ParaView 5.11's XDMF 3 reader aborts on a relative .xdmf path whose HDF5 file
# is named relative to it (as cassini writes them).
particles_file, fields_file, out = (os.path.abspath(a) for a in sys.argv[1:4])


def describe(source, label):
    source.UpdatePipeline()
    arrays = [f"{source.PointData.GetArray(i).GetName()}({source.PointData.GetArray(i).GetNumberOfComponents()})"
              for i in range(len(source.PointData))]
    bounds = source.GetDataInformation().GetBounds()
    print(f"{label}: {source.GetDataInformation().GetNumberOfPoints()} points, arrays {', '.join(arrays)}")
    print(f"{label}: bounds x [{bounds[0]:.4g}, {bounds[1]:.4g}] y [{bounds[2]:.4g}, {bounds[3]:.4g}] "
          f"z [{bounds[4]:.4g}, {bounds[5]:.4g}]")
    return bounds


def frame(view, bounds):
    # Look down z onto the x-y plane (the ring plane, the channel's plan view).
    cx, cy, cz = ((bounds[0] + bounds[1]) / 2, (bounds[2] + bounds[3]) / 2, (bounds[4] + bounds[5]) / 2)
    view.CameraPosition = [cx, cy, cz + 10 * max(bounds[1] - bounds[0], bounds[3] - bounds[2])]
    view.CameraFocalPoint = [cx, cy, cz]
    view.CameraViewUp = [0, 1, 0]
    view.CameraParallelProjection = 1
    ResetCamera(view)
    # Fill the picture: half its height in world units, whichever of width and height binds.
    w, h = bounds[1] - bounds[0], bounds[3] - bounds[2]
    aspect = view.ViewSize[0] / view.ViewSize[1]
    view.CameraParallelScale = 0.55 * max(h, w / aspect)


view = GetActiveViewOrCreate("RenderView")
view.ViewSize = [1400, 500]
view.OrientationAxesVisibility = 1

p = OpenDataFile(particles_file)
b = describe(p, "particles")
# Point Gaussian draws every point (the snapshot's Polyvertex topology renders as nothing in the
# surface representations) as a disc of the particle's size, or of a pixel or two when the box
# is much larger than a particle (a ring patch).
d = Show(p, view)
d.SetRepresentationType("Point Gaussian")
d.ShaderPreset = "Plain circle"
d.GaussianRadius = max(p.PointData["radius"].GetRange()[1], 1.2e-3 * max(b[1] - b[0], b[3] - b[2]))
ColorBy(d, ("POINTS", "velocity", "Magnitude"))
d.SetScalarBarVisibility(view, True)
frame(view, b)
SaveScreenshot(os.path.join(out, "particles.png"), view, ImageResolution=[1400, 500])
Hide(p, view)

f = OpenDataFile(fields_file)
b = describe(f, "fields")
d = Show(f, view)
ColorBy(d, ("POINTS", "density"))
d.SetScalarBarVisibility(view, True)
g = Glyph(Input=f, GlyphType="Arrow")
g.OrientationArray = ["POINTS", "velocity"]
g.ScaleArray = ["POINTS", "No scale array"]
g.ScaleFactor = 0.6 * (b[1] - b[0]) / 100
g.GlyphMode = "Every Nth Point"
g.Stride = 7
gd = Show(g, view)
gd.DiffuseColor = [1, 1, 1]
ColorBy(gd, None)
frame(view, b)
SaveScreenshot(os.path.join(out, "fields.png"), view, ImageResolution=[1400, 500])
print(f"wrote {out}/particles.png and {out}/fields.png")
