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

// Multi-orthographic camera bank: frame n renders view n of the list below.
// POV-Ray 3.7 shoots an orthographic pixel's ray from
//   location + ((col + 0.5)/W - 0.5) * right + (0.5 - (row + 0.5)/H) * up
// along `direction`, whatever the angle between `direction` and right/up.
// right/up span the lens array in a plane parallel to the screen and the
// location is backed off along the view direction <u/f, v/f, 1> by the clearance,
// so every ray crosses z = 0 exactly at its lens centre: no cosine squeeze,
// no drift.  (Shearing the scene instead would change its shading.)
#declare Povh3d_Directions = array[4] {
    <-0.08333333333333333, 0.08333333333333333, 1.0>, <0.08333333333333333, 0.08333333333333333, 1.0>, <-0.08333333333333333, -0.08333333333333333, 1.0>, <0.08333333333333333, -0.08333333333333333, 1.0>
};
#declare Povh3d_Frame = (frame_number > 0 ? frame_number - 1 : 0);
#declare Povh3d_Direction = Povh3d_Directions[Povh3d_Frame];
camera {
  orthographic
  location -10 * Povh3d_Direction
  direction Povh3d_Direction
  right <1, 0, 0>
  up <0, 1, 0>
}
