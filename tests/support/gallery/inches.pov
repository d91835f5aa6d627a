// A test scene in the style of a real one, in inches: a table top with two pieces,
// the camera looking down at the board with angle and look_at, a second camera
// earlier in the file (POV-Ray uses the last one).
#version 3.7;
global_settings { assumed_gamma 1.0 }
#declare Board = 12;      // inches across
#declare Eye = <-9, 14, -20>;

camera { location <0, 50, -100> look_at 0 }   // replaced by the next one

camera {
  location Eye
  right x * image_width / image_height
  angle 45
  look_at <0, 1, 0>
}

light_source { <-30, 50, -40> rgb 1 }
sky_sphere { pigment { rgb <0.6, 0.7, 0.9> } }
plane { y, -1 pigment { rgb 0.4 } }
box { <-Board / 2, -1, -Board / 2>, <Board / 2, 0, Board / 2>
      pigment { checker rgb 0.9 rgb 0.1 scale Board / 8 } }
cone { <-2, 0, 1>, 1.2, <-2, 4, 1>, 0.2 pigment { rgb <0.9, 0.8, 0.6> } }
sphere { <2.5, 1.5, -1.5>, 1.5 pigment { rgb <0.3, 0.1, 0.05> } finish { phong 0.6 } }
