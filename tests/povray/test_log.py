"""Tests of povh3d.povray_log against real POV-Ray 3.7 console output.

The logs below were captured from Debian's POV-Ray 3.7.0.10.unofficial run
exactly as povh3d runs it (``povh3d.povray.process.build_command`` in a job folder with
its private HOME), on small broken scenes; most are cut to start at the
"==== [Parsing...]" or "==== [Rendering...]" banner, keeping what follows
byte for byte (trailing spaces and POV-Ray's 80-column wrapping included).
To regenerate one, render the scene named in the comment with ``run_jobs``
and copy ``PovrayError.log_tail`` or ``JobResult.log``.
"""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from povh3d.povray.log import WRAP_WIDTH, parse_error, parse_render_time, unwrap

# Scenes start with 3 lines (#version, global_settings, camera); the broken
# line follows.
LOGS = {
    "parse_error": """\
==== [Parsing...] ==========================================================
File 'scene.pov' line 6: Parse Error: Expected 'object or directive', undeclared
 identifier 'Foo' found instead
Fatal error in parser: Cannot parse input.
Render failed

""",
    "undeclared_in_block": """\
==== [Parsing...] ==========================================================
File 'scene.pov' line 4: Parse Warning: Pigment type unspecified or not 1st
 item.
File 'scene.pov' line 4: Parse Error: No matching } in 'pigment', undeclared
 identifier 'Foo' found instead
Fatal error in parser: Cannot parse input.
Render failed

""",
    "missing_include": """\
==== [Parsing...] ==========================================================
File 'scene.pov' line 4: Possible Parse Error: Cannot find file 'nothere.inc',
 even after trying to append file type extension.
File 'scene.pov' line 4: Parse Error: Cannot open include file nothere.inc.
Fatal error in parser: Cannot parse input.
Render failed

""",
    "error_in_include": """\
==== [Parsing...] ==========================================================
File 'bad.inc' line 3: Parse Error: Expected '>', ; found instead
Fatal error in parser: Cannot parse input.
Render failed

""",
    "missing_image": """\
==== [Parsing...] ==========================================================
File 'scene.pov' line 4: Possible Parse Error: Cannot find file
 'missing_tex.png', even after trying to append file type extension.
File 'scene.pov' line 4: Possible Parse Error: Cannot find image file.
Fatal error in parser: Cannot open file.
Render failed

""",
    # advanced/cliche/cliche.pov of povray-examples, sign.png not yet rendered: a gamma
    # notice of the same line comes first and must not stand for the cause.
    "missing_image_after_notice": """\
==== [Parsing...] ==========================================================
File 'cliche.pov' line 105: Possible Parse Error: PNG input image default gamma
 handling has changed for pre POV-Ray 3.7 scenes; results may differ from
 original intention. See the documentation for more details.
File 'cliche.pov' line 105: Possible Parse Error: Cannot find file 'sign', even
 after trying to append file type extension.
File 'cliche.pov' line 105: Possible Parse Error: Cannot find image file.
Fatal error in parser: Cannot open file.
Render failed

""",
    "error_directive": """\
==== [Parsing...] ==========================================================
File 'scene.pov' line 4: Parse Error: Parse halted by #error directive: word1
 word2 word3 word4 word5 word6 word7 word8 word9 word10 word11 word12 word13
 word14
Fatal error in parser: Cannot parse input.
Render failed

""",
    "long_path": """\
==== [Parsing...] ==========================================================
File '/tmp/povexp_logs/a_really_long_directory_name_to_force_wrapping/and_anothe
r_really_long_subdirectory/averyverylongincludefilename.inc' line 2: Parse
 Error: Expected '>', ; found instead
Fatal error in parser: Cannot parse input.
Render failed

""",
    "fopen_denied": """\
==== [Parsing...] ==========================================================
File 'scene.pov' line 4: Parse Error: Cannot open user file /nonexistent/out.txt
 (write).
Fatal error in parser: Cannot parse input.
Render failed

""",
    "photon_error": """\
==== [Rendering...] ========================================================
Photon Warning: Starting the load of photon file missing.ph 
Photon Error: Could not load photon map (missing.ph)
Fatal error in renderer: Uncategorized error.
Render failed

""",
    "badopt": """\

Problem with option setting
povray +Iscene.pov +Oframe.png +W8 +H8 +FN8 File_Gamma=sRGB -D -V +Qzz
Failed to parse command-line option
""",
    "slow": """\
==== [Parsing...] ==========================================================
Parsing 13307K tokens
povray: received signal SIGTERM: Termination; requested render cancel
Parsing 26833K tokens
Fatal error in parser: Frontend halted render.
Fatal error in parser: Frontend halted render.
Render cancelled by user

""",
    "warning_only": """\
Persistence of Vision(tm) Ray Tracer Version 3.7.0.10.unofficial (g++ @
 x86_64-pc-linux-gnu)
This is an unofficial version compiled by:
 amd64 / i386 Build Daemon (x86-ubc-01) <buildd_amd64-x86-ubc-01@buildd.debian.o
rg> for Debian <www.debian.org>
 The POV-Ray Team is not responsible for supporting this version.

POV-Ray is based on DKBTrace 2.12 by David K. Buck & Aaron A. Collins
Copyright 1991-2013 Persistence of Vision Raytracer Pty. Ltd.

Primary POV-Ray 3.7 Architects/Developers: (Alphabetically)
  Chris Cason         Thorsten Froehlich  Christoph Lipka   

With Assistance From: (Alphabetically)
  Ton van den Broek   Nicolas Calimet     Jerome Grimbert     James Holsenback  
  Christoph Hormann   Nathan Kopp         Juha Nieminen     

Past Contributors: (Alphabetically)
  Steve Anger         Eric Barish         Dieter Bayer        David K. Buck     
  Nicolas Calimet     Chris Cason         Aaron A. Collins    Chris Dailey      
  Steve Demlow        Andreas Dilger      Alexander Enzmann   Dan Farmer        
  Thorsten Froehlich  Mark Gordon         James Holsenback    Christoph Hormann 
  Mike Hough          Chris Huff          Kari Kivisalo       Nathan Kopp       
  Lutz Kretzschmar    Christoph Lipka     Jochen Lippert      Pascal Massimino  
  Jim McElhiney       Douglas Muir        Juha Nieminen       Ron Parker        
  Bill Pulver         Eduard Schwan       Wlodzimierz Skiba   Robert Skinner    
  Yvo Smellenbergh    Zsolt Szalavari     Scott Taylor        Massimo Valentini 
  Timothy Wegner      Drew Wells          Chris Young       

Other contributors are listed in the documentation.

Support libraries used by POV-Ray:
  ZLib 1.2.13, Copyright 1995-2012 Jean-loup Gailly and Mark Adler
  LibPNG 1.6.39, Copyright 1998-2012 Glenn Randers-Pehrson
  LibJPEG , Copyright 1991-2013 Thomas G. Lane, Guido Vollbeding
  LibTIFF 4.5.0, Copyright 1988-1997 Sam Leffler, 1991-1997 SGI
  Boost 1.74, http://www.boost.org/
  OpenEXR 3.1.5 and Imath 3.1.5, Copyright (c) Contributors to the OpenEXR
 Project.

Parser Options
  Input file: scene.pov
  Remove bounds........On 
  Split unions.........Off
  Library paths:
    /usr/share/povray-3.7
    /usr/share/povray-3.7/ini
    /usr/share/povray-3.7/include
  Clock value:    0.000  (Animation off)
Image Output Options
  Image resolution.....8 by 8 (rows 1 to 8, columns 1 to 8).
  Output file..........frame.png, 24 bpp PNG
  Dithering............Off
  Graphic display......Off
  Mosaic preview.......Off
  Continued trace......Off
Information Output Options
  All Streams to console..........On 
  Debug Stream to console.........On 
  Fatal Stream to console.........On 
  Render Stream to console........On 
  Statistics Stream to console....On 
  Warning Stream to console.......On 
==== [Parsing...] ==========================================================
Possible Parse Error: assumed_gamma not specified in this POV-Ray 3.7 or later
 scene. Future versions of POV-Ray may consider this a fatal error. To avoid
 this warning, explicitly specify 'assumed_gamma 1.0' in the global_settings
 section. See the documentation for more details.
----------------------------------------------------------------------------
Parser Statistics
----------------------------------------------------------------------------
Finite Objects:            1
Infinite Objects:          0
Light Sources:             1
Total:                     2
----------------------------------------------------------------------------
Parser Time
  Parse Time:       0 hours  0 minutes  0 seconds (0.000 seconds)
              using 1 thread(s) with 0.000 CPU-seconds total
  Bounding Time:    0 hours  0 minutes  0 seconds (0.000 seconds)
              using 1 thread(s) with 0.000 CPU-seconds total
----------------------------------------------------------------------------
Render Options
  Quality:  9
  Bounding boxes.......On   Bounding threshold: 3
  Antialiasing.........Off
==== [Rendering...] ========================================================
----------------------------------------------------------------------------
Render Statistics
Image Resolution 8 x 8
----------------------------------------------------------------------------
Pixels:               64   Samples:               0   Smpls/Pxl: 0.00
Rays:                 64   Saved:                 0   Max Level: 1/5
----------------------------------------------------------------------------
Ray->Shape Intersection          Tests       Succeeded  Percentage
----------------------------------------------------------------------------
Sphere                              78              29     37.18
----------------------------------------------------------------------------
Shadow Ray Tests:                14   Succeeded:                     0
----------------------------------------------------------------------------
----------------------------------------------------------------------------
Render Time:
  Photon Time:      No photons
  Radiosity Time:   No radiosity
  Trace Time:       0 hours  0 minutes  0 seconds (0.001 seconds)
              using 2 thread(s) with 0.000 CPU-seconds total
POV-Ray finished

""",
    "heavy": """\
==== [Rendering...] ========================================================
----------------------------------------------------------------------------
Render Statistics
Image Resolution 400 x 300
----------------------------------------------------------------------------
Pixels:           128635   Samples:         5090619   Smpls/Pxl: 39.57
Rays:           13955428   Saved:            239049   Max Level: 5/5
----------------------------------------------------------------------------
Ray->Shape Intersection          Tests       Succeeded  Percentage
----------------------------------------------------------------------------
Plane                         20102552         9065049     45.09
Sphere                        38868971        17703264     45.55
Bounding Box                 358361922       103054344     28.76
----------------------------------------------------------------------------
Shadow Ray Tests:           7542261   Succeeded:               1853391
Shadow Cache Hits:          1153214
Reflected Rays:             8675044
----------------------------------------------------------------------------
Radiosity samples calculated:             3698 (0.04 %)
Radiosity samples reused:             10018326
Radiosity sample rays shot:              61130
Radiosity octree nodes:                   1295
Radiosity octree samples/node:            2.86
Radiosity blocks examined:          5060097323
Radiosity blocks passed test 0:     5060097323 (100.00 %)
Radiosity blocks passed test 1:     1121703836 (22.17 %)
Radiosity blocks passed test 2:      826731563 (16.34 %)
Radiosity blocks passed test 3:      127961740 (2.53 %)
Radiosity blocks passed test 4:       79179266 (1.56 %)
Radiosity blocks passed test 5:       74518696 (1.47 %)
Radiosity blocks rejected:          4985578627 (98.53 %)
----------------------------------------------------------------------------
Radiosity Depth 0 calculated:             2415 (0.02 %)
Radiosity Depth 0 reused:              9954569
Radiosity Depth 0 rays shot:             48300
----------------------------------------------------------------------------
Radiosity (final) calculated:             1781 (0.02 %)
Radiosity (final) reused:             10009270
Radiosity (final) rays shot:             35460
----------------------------------------------------------------------------
  Pass     Depth 0    Depth 1           Total
----------------------------------------------------------------------------
  1            170        558             728
  2            480        709            1189
  Final       1765         16            1781
----------------------------------------------------------------------------
  Total       2415       1283            3698
  Weight     0.350      0.148 
----------------------------------------------------------------------------
----------------------------------------------------------------------------
Render Time:
  Photon Time:      No photons
  Radiosity Time:   0 hours  0 minutes  0 seconds (0.037 seconds)
              using 2 thread(s) with 0.065 CPU-seconds total
  Trace Time:       0 hours  0 minutes 21 seconds (21.757 seconds)
              using 2 thread(s) with 41.637 CPU-seconds total
POV-Ray finished

""",
    "anim": """\
Render Time:
  Photon Time:      No photons
  Radiosity Time:   No radiosity
  Trace Time:       0 hours  0 minutes  0 seconds (0.201 seconds)
              using 2 thread(s) with 0.240 CPU-seconds total

Rendering frame 2 of 2

Parser Options
  Input file: scene.pov
  Remove bounds........On 
  Split unions.........Off
  Library paths:
    /usr/share/povray-3.7
    /usr/share/povray-3.7/ini
    /usr/share/povray-3.7/include
Animation Options
  Initial Frame:        1  Final Frame:        2
  Frame Step:           1
  Initial Clock:    0.000  Final Clock:    0.000
  Cyclic Animation.....Off  Field render.........Off  Odd lines/frames.....Off
Image Output Options
  Image resolution.....160 by 120 (rows 1 to 120, columns 1 to 160).
  Output file..........frame2.png, 24 bpp PNG
  Dithering............Off
  Graphic display......Off
  Mosaic preview.......Off
  Continued trace......Off
Information Output Options
  All Streams to console..........On 
  Debug Stream to console.........On 
  Fatal Stream to console.........On 
  Render Stream to console........On 
  Statistics Stream to console....On 
  Warning Stream to console.......On 
==== [Parsing...] ==========================================================
----------------------------------------------------------------------------
Parser Statistics
----------------------------------------------------------------------------
Finite Objects:          201
Infinite Objects:          0
Light Sources:             1
Total:                   202
----------------------------------------------------------------------------
Parser Time
  Parse Time:       0 hours  0 minutes  0 seconds (0.001 seconds)
              using 1 thread(s) with 0.000 CPU-seconds total
  Bounding Time:    0 hours  0 minutes  0 seconds (0.000 seconds)
              using 1 thread(s) with 0.000 CPU-seconds total
----------------------------------------------------------------------------
Render Options
  Quality:  9
  Bounding boxes.......On   Bounding threshold: 3
  Antialiasing.........On  (Method 2, Threshold 0.010, Depth 3, Jitter 1.00,
 Gamma 2.50)
==== [Rendering...] ========================================================
----------------------------------------------------------------------------
Render Statistics
Image Resolution 160 x 120
----------------------------------------------------------------------------
Pixels:            20460   Samples:          242388   Smpls/Pxl: 11.85
Rays:             658651   Saved:             10800   Max Level: 5/5
----------------------------------------------------------------------------
Ray->Shape Intersection          Tests       Succeeded  Percentage
----------------------------------------------------------------------------
Sphere                         1704401          782395     45.90
Bounding Box                  17023023         5525259     32.46
----------------------------------------------------------------------------
Shadow Ray Tests:            282006   Succeeded:                 49556
Shadow Cache Hits:            42414
Reflected Rays:              395803
----------------------------------------------------------------------------
----------------------------------------------------------------------------
Render Time:
  Photon Time:      No photons
  Radiosity Time:   No radiosity
  Trace Time:       0 hours  0 minutes  0 seconds (0.126 seconds)
              using 2 thread(s) with 0.245 CPU-seconds total
POV-Ray finished

""",
}

# Not reproducible here: Debian's build parses but never enforces its
# [File I/O Security] setting (an inverted comparison in
# vfe/unix/unixoptions.cpp), so this log is built from the wording in POV-Ray
# 3.7's source (unixoptions.cpp, base/fileinputoutput.cpp).
IO_RESTRICTION_LOG = """\
povray: reading from '/data/textures/wood.png' is not permitted; check the configuration in '/home/u/.povray/3.7/povray.conf'
==== [Parsing...] ==========================================================
File 'scene.pov' line 4: Possible Parse Error: Cannot find image file.
Fatal error in parser: Cannot open file.
Render failed
"""


@pytest.mark.parametrize(("name", "expected"), [
    # Foo at top level of a scene.
    ("parse_error", "scene.pov line 6: Parse Error: Expected 'object or directive', "
                    "undeclared identifier 'Foo' found instead"),
    # A warning on the same line comes first and is not the error.
    ("undeclared_in_block", "scene.pov line 4: Parse Error: No matching } in 'pigment', "
                            "undeclared identifier 'Foo' found instead"),
    # '#include "nothere.inc"': the "Possible Parse Error" before it is skipped.
    ("missing_include", "scene.pov line 4: Parse Error: Cannot open include file nothere.inc."),
    # The error is in the include file, which POV-Ray names.
    ("error_in_include", "bad.inc line 3: Parse Error: Expected '>', ; found instead"),
    # A missing image_map file: only possible errors, then a fatal one.
    ("missing_image", "scene.pov line 4: Cannot find file 'missing_tex.png', even after "
                      "trying to append file type extension. "
                      "(Fatal error in parser: Cannot open file.)"),
    ("missing_image_after_notice", "cliche.pov line 105: Cannot find file 'sign', even after trying to "
                                   "append file type extension. (Fatal error in parser: Cannot open file.)"),
    ("error_directive", "scene.pov line 4: Parse Error: Parse halted by #error directive: "
                        "word1 word2 word3 word4 word5 word6 word7 word8 word9 word10 "
                        "word11 word12 word13 word14"),
    # The path is hard-wrapped at column 80, then "Parse Error" word-wrapped.
    ("long_path", "/tmp/povexp_logs/a_really_long_directory_name_to_force_wrapping/"
                  "and_another_really_long_subdirectory/averyverylongincludefilename.inc"
                  " line 2: Parse Error: Expected '>', ; found instead"),
    # '#fopen F "/nonexistent/out.txt" write'
    ("fopen_denied", "scene.pov line 4: Parse Error: Cannot open user file "
                     "/nonexistent/out.txt (write)."),
    # A render-time error: photons { load_file "missing.ph" }.
    ("photon_error", "Photon Error: Could not load photon map (missing.ph)"),
    # Extra switch "+Qzz".
    ("badopt", "Failed to parse command-line option"),
    # An endless #while loop stopped with SIGTERM.
    ("slow", "Fatal error in parser: Frontend halted render."),
    # Renders that succeeded: warnings ("Possible Parse Error") are no error.
    ("warning_only", None),
    ("heavy", None),
    ("anim", None),
])
def test_parse_error_real_logs(name: str, expected: str | None) -> None:
    assert parse_error(LOGS[name]) == expected


def test_parse_error_io_restriction() -> None:
    assert parse_error(IO_RESTRICTION_LOG) == (
        "reading from '/data/textures/wood.png' is not permitted; check the "
        "configuration in '/home/u/.povray/3.7/povray.conf'")


def test_parse_error_empty_log() -> None:
    assert parse_error("") is None


def test_parse_error_accepts_carriage_returns() -> None:
    log = LOGS["parse_error"].replace("\n", "\r\n")
    assert parse_error(log) == parse_error(LOGS["parse_error"])


@pytest.mark.parametrize(("name", "seconds"), [
    ("warning_only", 0.001),
    ("heavy", 0.037 + 21.757),  # radiosity + trace
    ("anim", 0.201 + 0.126),    # two frames
    ("parse_error", None),
    ("photon_error", None),
])
def test_parse_render_time(name: str, seconds: float | None) -> None:
    assert parse_render_time(LOGS[name]) == pytest.approx(seconds)


def test_unwrap_keeps_unwrapped_lines() -> None:
    lines = unwrap(LOGS["warning_only"])
    # Lines from POV-Ray's stderr are longer than 80 and never wrapped: the
    # banner line after them stays separate.
    assert lines[0].startswith("Persistence of Vision(tm) Ray Tracer Version 3.7")
    # An indented line after a short one is a line of its own.
    assert "This is an unofficial version compiled by:" in lines
    assert "Parser Statistics" in lines


def _pov_wrap(message: str) -> list[str]:
    """Wrap like POV-Ray's console: at the last space that fits, else at 80."""
    lines = []
    while len(message) > WRAP_WIDTH:
        cut = message.rfind(" ", 1, WRAP_WIDTH + 1)
        cut = cut if cut > 0 else WRAP_WIDTH
        lines.append(message[:cut])
        message = message[cut:]
    return [*lines, message]


# Lowercase words: they cannot look like the start of a POV-Ray message.
_words = st.lists(st.text("abcdefghijklmnopqrstuvwxyz0123456789_./'(),", min_size=1,
                          max_size=120), min_size=1, max_size=30)


@given(_words)
def test_unwrap_inverts_wrapping(words: list[str]) -> None:
    message = "File 'scene.pov' line 3: Parse Error: " + " ".join(words)
    log = "\n".join(["==== [Parsing...] ====", *_pov_wrap(message),
                     "Fatal error in parser: Cannot parse input.", "Render failed"])
    assert unwrap(log) == ["==== [Parsing...] ====", message,
                           "Fatal error in parser: Cannot parse input.", "Render failed"]


# Verbose (+V) output of Debian's POV-Ray 3.7.0.10 rendering frames 1..3 of 200x100 (abridged).
VERBOSE_ANIMATION = ("Rendering frame 1 of 3\nRendering frame 1 of 3\n==== [Parsing...] ====\n"
                     "Rendered 4096 of 20000 pixels (20%)\rRendered 20000 of 20000 pixels (100%)\n"
                     "Render Statistics\nRendering frame 2 of 3\n==== [Parsing...] ====\n"
                     "Rendered 1024 of 20000 pixels (5%)\rRendered 5000 of 20000 pixels (25%)\r")


def test_parse_progress_counts_finished_frames_and_the_current_share():
    from povh3d.povray.log import parse_progress

    assert parse_progress("") == (1, 0.0)
    assert parse_progress(VERBOSE_ANIMATION) == (2, 0.25)
    # read in pieces, carrying the state: the same answer
    first, rest = VERBOSE_ANIMATION[:120], VERBOSE_ANIMATION[120:]
    assert parse_progress(rest, *parse_progress(first)) == (2, 0.25)
    # the repeated "frame 1" line does not reset the share already read
    assert parse_progress("Rendering frame 1 of 3\n", 1, 0.5) == (1, 0.5)


def test_error_tail_leaves_out_the_pixel_counts():
    from povh3d.povray.log import describe_exit, tail

    log = VERBOSE_ANIMATION + "\nFatal error in renderer: Out of memory.\n"
    assert "Rendered" not in tail(log) and "Out of memory" in tail(log)
    assert describe_exit(1, VERBOSE_ANIMATION) == "POV-Ray exited with code 1: ==== [Parsing...] ===="


# POV-Ray 3.7.0.10's log for `#include "pièce.inc"` (pasted): it replaced each byte of "è".
NON_ASCII_LOG = """==== [Parsing...] ==========================================================
File 's.pov' line 5: Possible Parse Error: Non-ASCII character has been replaced
 by space character.
File 's.pov' line 5: Possible Parse Error: Non-ASCII character has been replaced
 by space character.
File 's.pov' line 5: Possible Parse Error: Cannot find file 'pi  ce.inc', even
 after trying to append file type extension.
File 's.pov' line 5: Parse Error: Cannot open include file pi  ce.inc.
Fatal error in parser: Cannot parse input.
"""


def test_denied_note_names_povrays_ascii_file_names_only_on_the_failing_line() -> None:
    from povh3d.povray.log import denied_note

    reason = parse_error(NON_ASCII_LOG)
    assert reason == "s.pov line 5: Parse Error: Cannot open include file pi  ce.inc."
    assert "as ASCII" in denied_note(reason, (), NON_ASCII_LOG) and "rename the file" in denied_note(reason, (), NON_ASCII_LOG)
    # A non-ASCII string on another line does not explain a missing include.
    other = NON_ASCII_LOG.replace("line 5: Parse Error: Cannot open include file pi  ce.inc",
                                  "line 7: Parse Error: Cannot open include file nothere.inc")
    note = denied_note(parse_error(other), (), other, confined=False)
    assert "as ASCII" not in note and "neither beside the scene" in note


def test_past_scene_end_rewrites_only_povh3ds_own_script() -> None:
    from povh3d.povray.log import past_scene_end

    ours = "pinhole camera 1: scene.pov line 87: Parse Error: No matching } in 'sphere', camera found instead"
    assert past_scene_end(ours, "mine.pov") == ("pinhole camera 1: POV-Ray read past the end of mine.pov into "
                                                "povh3d's own script, so look at the end of mine.pov (an unclosed "
                                                "brace, a missing ';'): Parse Error: No matching } in 'sphere', "
                                                "camera found instead")
    theirs = "pinhole camera 1: /home/u/scene.pov line 3: Parse Error: Expected 'object'"  # the user's own scene.pov
    assert past_scene_end(theirs, "scene.pov") == theirs
