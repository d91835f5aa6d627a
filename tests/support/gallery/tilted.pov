// A test scene in the style of a real one: metres, its own camera set by declared
// identifiers from an include, tilted and rolled (sky), a sky_sphere and a ground plane.
#version 3.7;
global_settings { assumed_gamma 1.0 max_trace_level 5 }
#include "colors.inc"
#include "gallery_camera.inc"

camera {
  perspective
  location Cam_Location
  sky Cam_Sky
  right x * image_width / image_height
  angle 32
  look_at Cam_Target
}

light_source { <-4, 6, -5> color rgb <1, 0.97, 0.9> }
light_source { <5, 3, -2> color rgb 0.3 shadowless }
sky_sphere { pigment { gradient y color_map { [0 rgb <0.75, 0.85, 1>] [1 rgb <0.2, 0.35, 0.8>] } } }
plane { y, 0 pigment { checker rgb 0.85 rgb 0.25 scale 0.25 } }
sphere { <0.35, 0.42, -0.10>, 0.42 pigment { checker rgb <0.9, 0.35, 0.1> rgb <0.2, 0.2, 0.6> scale 0.12 } }
box { <-0.9, 0, 0.3>, <-0.3, 0.6, 0.9> rotate 20 * y pigment { rgb <0.2, 0.7, 0.3> } }
cylinder { <1.1, 0, 0.2>, <1.1, 0.95, 0.2>, 0.15 // top cap off the stripes' colour boundaries (multiples of 0.15)
  pigment { gradient y color_map { [0.5 rgb 1] [0.5 rgb <0.7, 0.1, 0.1>] } scale 0.15 } }
