// povh3d sample scene: lit, textured, objects in front of and behind the screen.
// No camera: povh3d adds the camera bank.  Scene units are mm; the display
// plane is z = 0 and the viewer stands on the -z side (objects at z < 0 float
// in front of the screen).  The scene sizes itself to the panel povh3d declares.
#version 3.7;
global_settings { assumed_gamma 1.0 }

#ifndef (Povh3d_Panel_Width) #declare Povh3d_Panel_Width = 32; #end
#ifndef (Povh3d_Panel_Height) #declare Povh3d_Panel_Height = 24; #end
#declare S = min(Povh3d_Panel_Width, 4/3 * Povh3d_Panel_Height) / 32;  // 1 unit = 1 mm on the demo panel

background { rgb <0.02, 0.02, 0.03> }
light_source { <-40, 60, -80> * S rgb <1.0, 0.95, 0.9> }
light_source { < 60, 20, -40> * S rgb <0.25, 0.3, 0.4> shadowless }

// Behind the screen: a checkered back wall and a marbled sphere.
plane { z, 11.5 * S hollow  // hollow: the viewer is "inside" this half-space, and fog (povh3d's depth pass) only fills hollow objects; inside the depth budget (+-12 mm on demo); not a whole number of checker squares, the checker flips on whole z
  pigment { checker rgb <0.85, 0.85, 0.8> rgb <0.25, 0.35, 0.55> scale 3 * S }
  finish { diffuse 0.8 ambient 0.05 }
}
sphere { <-6, -1, 6> * S, 5 * S
  pigment { marble turbulence 0.8 color_map { [0 rgb <0.9, 0.3, 0.1>] [0.5 rgb <1, 0.85, 0.4>] [1 rgb <0.6, 0.1, 0.05>] } scale 2 * S }
  finish { specular 0.4 roughness 0.02 diffuse 0.75 ambient 0.05 }
}

// Across the screen: a striped cylinder from behind to in front.
cylinder { <6, -7, 5> * S, <9, -4, -4> * S, 1.5 * S
  pigment { gradient y color_map { [0 rgb <0.1, 0.6, 0.2>] [0.5 rgb <0.1, 0.6, 0.2>] [0.5 rgb 0.95] [1 rgb 0.95] } scale 1.5 * S }
  finish { diffuse 0.8 ambient 0.05 }
}

// In front of the screen: a golden torus and a small blue box.
torus { 3 * S, 0.9 * S rotate 70 * x rotate -25 * y translate <7, 5, -3> * S
  pigment { rgb <0.95, 0.75, 0.25> }
  finish { specular 0.6 roughness 0.01 metallic diffuse 0.7 ambient 0.05 }
}
box { <-2, -2, -2> * S, <2, 2, 2> * S rotate <30, 40, 0> translate <-5, -7, -3> * S
  pigment { bozo color_map { [0 rgb <0.1, 0.2, 0.8>] [1 rgb <0.5, 0.7, 1>] } scale 0.8 * S }
  finish { diffuse 0.8 ambient 0.05 }
}
