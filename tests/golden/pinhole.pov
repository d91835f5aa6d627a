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

// Per-lens pinhole cameras: frame n renders the elemental image of lens n below.
// POV-Ray's perspective pixel (k, l) looks along
//   direction + ((k + 0.5)/Nx - 0.5) * right + (0.5 - (l + 0.5)/Ny) * up = (u_k, v_l, f).
// A pinhole sees only what lies behind the screen (z > 0).
#declare Povh3d_Centres = array[4] {
    <-0.25, 0.25, 0.0>, <0.25, 0.25, 0.0>, <-0.25, -0.25, 0.0>, <0.25, -0.25, 0.0>
};
#declare Povh3d_Frame = (frame_number > 0 ? frame_number - 1 : 0);
camera {
  perspective
  location Povh3d_Centres[Povh3d_Frame]
  direction <0, 0, 1.5>
  right <0.5, 0, 0>
  up <0, 0.5, 0>
}
