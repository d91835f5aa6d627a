// povh3d bench scene: a finely textured back wall (detail near the panel's own
// pixel size, so how each pixel's footprint is integrated shows), a reflective
// sphere (so the trace depth matters) and an object in front of the screen.
// No camera; sizes itself to the panel povh3d declares (mm; display plane z = 0).
#version 3.7;
global_settings { assumed_gamma 1.0 max_trace_level 8 }

#ifndef (Povh3d_Panel_Width) #declare Povh3d_Panel_Width = 24; #end
#ifndef (Povh3d_Panel_Height) #declare Povh3d_Panel_Height = 14.4; #end
#ifndef (Povh3d_Lens_Pitch) #declare Povh3d_Lens_Pitch = 0.8; #end
#declare S = min(Povh3d_Panel_Width, 5/3 * Povh3d_Panel_Height) / 24;

background { rgb <0.05, 0.05, 0.08> }
light_source { <-30, 40, -60> * S rgb 1 }
light_source { < 40, 10, -30> * S rgb 0.3 shadowless }

// Behind the screen: a wall whose texture repeats about every lens pitch.
plane { z, 7.3 * S
  pigment { granite color_map { [0 rgb <0.15, 0.2, 0.4>] [0.5 rgb <0.9, 0.85, 0.7>] [1 rgb <0.5, 0.1, 0.1>] }
            scale 1.5 * Povh3d_Lens_Pitch }
  finish { diffuse 0.9 ambient 0.05 }
}
// Across the screen: a mirror-like sphere reflecting the wall and a box.
sphere { <-3.5, 0.5, 1.5> * S, 3.2 * S
  pigment { rgb <0.7, 0.75, 0.8> }
  finish { reflection { 0.6 } specular 0.5 roughness 0.01 diffuse 0.3 ambient 0.02 }
}
// In front of the screen: a wavy striped box.
box { <-2, -2, -1> * S, <2, 2, 1> * S rotate <20, -35, 10> translate <5, -1.5, -2.5> * S
  pigment { gradient x color_map { [0 rgb <0.9, 0.5, 0.1>] [0.5 rgb <0.9, 0.5, 0.1>] [0.5 rgb 0.95] [1 rgb 0.95] }
            scale 0.6 * S warp { turbulence 0.3 } }
  finish { diffuse 0.85 ambient 0.05 }
}
