"""pvpython side of scripts/paraview-screenshots (see there)."""
import os
import sys

from paraview.simple import (ColorBy, Glyph, GetActiveViewOrCreate, GetColorTransferFunction, OpenDataFile,
                             ResetCamera, SaveScreenshot, Show, Hide)

particles_file, fields_file, out = sys.argv[1:4]


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


view = GetActiveViewOrCreate("RenderView")
view.ViewSize = [1400, 500]
view.OrientationAxesVisibility = 1

p = OpenDataFile(particles_file)
b = describe(p, "particles")
d = Show(p, view)
d.SetRepresentationType("Points")
d.PointSize = 2
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
