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

// The multi-orthographic camera bank in one pass.  Each lens is a face of this
// mesh; mesh_camera distribution 3 looks image pixel (col, row) up at UV
// (col/W, 1 - row/H) and, with `smooth`, shoots from the interpolated vertex
// along the interpolated normal: through the lens centre with direction
// (u, v, f), exactly the ray of that pixel's view.  POV-Ray looks image row 0
// and the last column up half a pixel off, so the image has one extra row on
// top and one extra column on the right, which povh3d cuts off.
#declare Povh3d_Camera_Mesh = mesh2 {
  vertex_vectors { 16,
    <1.0, -3.0, -12.0>, <3.0, -3.0, -12.0>, <3.0, -1.0, -12.0>, <1.0, -1.0, -12.0>,
    <-3.0, -3.0, -12.0>, <-1.0, -3.0, -12.0>, <-1.0, -1.0, -12.0>, <-3.0, -1.0, -12.0>,
    <1.0, 1.0, -12.0>, <3.0, 1.0, -12.0>, <3.0, 3.0, -12.0>, <1.0, 3.0, -12.0>,
    <-3.0, 1.0, -12.0>, <-1.0, 1.0, -12.0>, <-1.0, 3.0, -12.0>, <-3.0, 3.0, -12.0>
  }
  normal_vectors { 16,
    <-0.0625, 0.0625, 1.5>, <-0.0625, 0.0625, 1.5>, <-0.0625, 0.0625, 1.5>, <-0.0625, 0.0625, 1.5>,
    <0.0625, 0.0625, 1.5>, <0.0625, 0.0625, 1.5>, <0.0625, 0.0625, 1.5>, <0.0625, 0.0625, 1.5>,
    <-0.0625, -0.0625, 1.5>, <-0.0625, -0.0625, 1.5>, <-0.0625, -0.0625, 1.5>, <-0.0625, -0.0625, 1.5>,
    <0.0625, -0.0625, 1.5>, <0.0625, -0.0625, 1.5>, <0.0625, -0.0625, 1.5>, <0.0625, -0.0625, 1.5>
  }
  uv_vectors { 16,
    <-0.1, 0.5>, <0.3, 0.5>, <0.3, 0.9>, <-0.1, 0.9>,
    <0.3, 0.5>, <0.7, 0.5>, <0.7, 0.9>, <0.3, 0.9>,
    <-0.1, 0.09999999999999998>, <0.3, 0.09999999999999998>, <0.3, 0.5>, <-0.1, 0.5>,
    <0.3, 0.09999999999999998>, <0.7, 0.09999999999999998>, <0.7, 0.5>, <0.3, 0.5>
  }
  face_indices { 8,
    <0, 1, 2>, <0, 2, 3>, <4, 5, 6>, <4, 6, 7>,
    <8, 9, 10>, <8, 10, 11>, <12, 13, 14>, <12, 14, 15>
  }
  // Vertices in lens pitches, exact in single precision; to mm in double precision.
  scale <0.5, 0.5, 1>
}
camera { mesh_camera { 1 3 mesh { Povh3d_Camera_Mesh } smooth } }
