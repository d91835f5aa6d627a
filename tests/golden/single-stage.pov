// header line
#version 3.7;
// The scene sets no assumed_gamma: use POV-Ray 3.7's linear default.
global_settings { assumed_gamma 1.0 }
// The display, for scenes that fit themselves to it (mm).
#declare Povh3d_Panel_Width = 1;
#declare Povh3d_Panel_Height = 1;
#declare Povh3d_Lens_Pitch = 0.5;
#declare Povh3d_Focal = 1.5;
#include "/scenes/tiny.pov"

// Single-stage rendering (thesis 3.3): a virtual array of plano-convex lenslets
// rendered by one orthographic camera, the capture panel, in one pass.
// Flat faces toward the camera at z = -13.507507586901914, curved vertices (the rear
// principal plane) at z = -13.5: every lens focuses the camera's
// parallel rays on its own point of the focal plane z = -12.
// povh3d turns each elemental image by 180 degrees afterwards (orthoscopic)
// and, when the focal plane lies in front of the screen, shifts each view by a
// whole number of lenses so that the rays cross z = 0 at the lens centres.
// Hex / fractional PPL: the camera grid is aligned to the lens centres (same
// sample offsets in every lens), so the samples are views that shift the same way.
// Lenslet: conic, ior 6.56, R 8.34 mm, K -43.03359999999999.
#declare Povh3d_Lenslet = intersection {
  box { <-0.25, -0.25, -0.007507586901914622>, <0.25, 0.25, 0> }
  // Hyperboloid K = -n^2: negative inside the glass.
  quadric { <1, 1, -42.03359999999999>, <0, 0, 0>, <0, 0, 16.68>, 0 }
  bounded_by { box { <-0.25, -0.25, -0.007507586901914622>, <0.25, 0.25, 0> } }
  texture { pigment { rgbf 1 } finish { ambient 0 diffuse 0 specular 0 phong 0 reflection 0 } }
  interior { ior 6.56 }
  no_shadow
  no_reflection
}
// Centres from indices (docs/geometry.md), never by accumulation: no drift.
#declare Povh3d_I = 0;
#while (Povh3d_I < 6)
  #declare Povh3d_Y = (6 / 2 - Povh3d_I - 0.5) * 0.5;
  #declare Povh3d_Shift = 0;
  #declare Povh3d_J = 0;
  #while (Povh3d_J < 6)
    object { Povh3d_Lenslet translate <(Povh3d_J + 0.5 - 6 / 2) * 0.5 + Povh3d_Shift, Povh3d_Y, -13.5> }
    #declare Povh3d_J = Povh3d_J + 1;
  #end
  #declare Povh3d_I = Povh3d_I + 1;
#end
camera {
  orthographic
  location <0, 0, -15.007507586901914>
  direction <0, 0, 1>
  right <3, 0, 0>
  up <0, 3, 0>
}
