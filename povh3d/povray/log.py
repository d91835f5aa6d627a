"""Read POV-Ray 3.7's console output: its error message and its render time.

Pure functions over the text of a log (stdout and stderr together); no I/O.
They are tested against logs captured from Debian's POV-Ray 3.7.0.10.

POV-Ray wraps console lines at 80 columns: at the last space that fits (the
space starts the next line) or, inside a long word such as a path, exactly at
column 80.  `unwrap` undoes both, so a message is one line again.
"""

from __future__ import annotations

import os
import re

__all__ = ["parse_error", "parse_progress", "parse_render_time", "unwrap"]

#: Column at which POV-Ray wraps its console output.
WRAP_WIDTH = 80

# Lines that start a message of their own, never the tail of a long word.
_MESSAGE_START = re.compile(
    r"^(?:File '|Fatal error|Possible |Parse |Render|POV-Ray|povray:|=+ |-{10})")
_LOCATION = re.compile(r"^File '(?P<file>.+?)' line (?P<line>\d+): (?P<message>.*)$")
# "Parse Error: ...", "Photon Error: ...": at most one word before "Error", so
# "Possible Parse Error" (a warning, the render goes on) never matches.
_ERROR = re.compile(r"^(?:[A-Z]\w* )?Error: ")
_POSSIBLE = re.compile(r"^Possible \w+ Error: ")
_FATAL = re.compile(r"^Fatal error in \w+: ")
_NAMES_FILE = re.compile(r"Cannot find file '")
# I/O restriction messages of POV-Ray 3.7 builds whose restrictions work (the
# Debian build ignores its [File I/O Security] setting) and the OS's refusal.
_ACCESS = re.compile(r"IO Restrictions prohibit|is not permitted|Permission denied")
# Failures POV-Ray reports in plain words, without "Error".
_PLAIN = ("Failed to parse command-line option",
          "Cannot create render state output file",
          "Cannot open input file")
# Verbose (+V) progress: "Rendering frame 2 of 8" (animations), then
# "Rendered 1024 of 480000 pixels (0%)" lines, ended by \r on a console.
_PROGRESS = re.compile(r"Rendering frame (?P<frame>\d+) of \d+|Rendered (?P<done>\d+) of (?P<total>\d+) pixels")
_PIXEL_LINE = re.compile(r"Rendered \d+ of \d+ pixels")
_SECONDS = re.compile(
    r"^\s*(?:Photon|Radiosity|Trace) Time:.*\((?P<seconds>\d+(?:\.\d+)?) seconds\)")


def unwrap(log: str) -> list[str]:
    """Split a log into lines, joining the lines POV-Ray wrapped.

    Parameters
    ----------
    log : str
        POV-Ray's console output.

    Returns
    -------
    list of str
        One entry per message line, without line terminators.
    """
    lines: list[str] = []
    last = ""  # the previous physical line: its length decides a wrap
    for line in re.split(r"\r\n|\r|\n", log):
        if lines and _continues(last, line):
            lines[-1] += line
        else:
            lines.append(line)
        last = line
    return lines


def _continues(previous: str, line: str) -> bool:
    """Whether `line` is the wrapped tail of `previous`."""
    if not previous or not line or len(previous) > WRAP_WIDTH:
        return False  # longer lines come unwrapped from POV-Ray's stderr
    if line[0] == " ":
        # A word wrap: one space, and the word would not have fitted before.
        word = line[1:].split(" ", 1)[0]
        return bool(word) and len(previous) + 1 + len(word) > WRAP_WIDTH
    # A hard break inside a long word; a message exactly 80 wide ends there too.
    return len(previous) == WRAP_WIDTH and not _MESSAGE_START.match(line)


def parse_error(log: str) -> str | None:
    """POV-Ray's own error message, on one line.

    Parameters
    ----------
    log : str
        POV-Ray's console output.

    Returns
    -------
    str or None
        The first real error, with its file and line when POV-Ray gives them,
        e.g. ``"scene.pov line 12: Parse Error: Expected 'object', ..."``;
        else an I/O refusal, a fatal error or a plain-worded failure; None if
        the log holds no error.  Warnings, including "Possible Parse Error",
        are not errors, though one may explain a fatal error that follows it.
    """
    from ..errors import param   # here: log.py stays a leaf of the import graph

    lines = [line.strip() for line in unwrap(log)]
    for find in (_first_error, _access_error, _fatal_error, _plain_error):
        message = find(lines)
        if message is not None:
            if "bad_alloc" in message or "out of memory" in message.lower():
                message += (" (POV-Ray ran out of the memory it may use: the memory available, or "
                            f"{param('max_memory')}; look for huge arrays or meshes in the scene)")
            return message
    return None


def _split_location(line: str) -> tuple[str, str]:
    """``("scene.pov line 12", message)``, or ``("", line)`` without a location."""
    match = _LOCATION.match(line)
    if match is None:
        return "", line
    return f"{match['file']} line {match['line']}", match["message"]


def _join(where: str, message: str) -> str:
    return f"{where}: {message}" if where else message


def _first_error(lines: list[str]) -> str | None:
    for line in lines:
        where, message = _split_location(line)
        if _ERROR.match(message):
            return _join(where, message)
    return None


def _access_error(lines: list[str]) -> str | None:
    for line in lines:
        if _ACCESS.search(line):
            where, message = _split_location(line.removeprefix("povray: "))
            return _join(where, message)
    return None


def _fatal_error(lines: list[str]) -> str | None:
    """A fatal error, explained by the located warnings just before it.

    A missing image_map file, for one, gives only "Possible Parse Error: Cannot
    find file 'x.png'" and then "Fatal error in parser: Cannot open file."
    """
    for index, line in enumerate(lines):
        if _FATAL.match(line):
            cause = _cause(lines[:index])
            return f"{cause} ({line})" if cause else line
    return None


def _cause(before: list[str]) -> str | None:
    """The located possible error, of those that end `before`, that names the missing file.

    Other warnings of the same line may come first (a PNG's gamma notice, in
    ``cliche.pov``): the one that names a file says what to fix; without one,
    the first of the run.
    """
    run: list[str] = []
    for line in reversed(before):
        where, message = _split_location(line)
        if not (where and _POSSIBLE.match(message)):
            break
        run.insert(0, _join(where, _POSSIBLE.sub("", message)))
    named = [cause for cause in run if _NAMES_FILE.search(cause)]
    return (named or run)[0] if run else None


def _plain_error(lines: list[str]) -> str | None:
    for line in lines:
        if line.startswith(_PLAIN):
            return line
    return None


def parse_render_time(log: str) -> float | None:
    """Seconds POV-Ray spent rendering, from its statistics.

    Parameters
    ----------
    log : str
        POV-Ray's console output.

    Returns
    -------
    float or None
        Sum of the photon, radiosity and trace times over every frame, s
        (parsing excluded); None if the log reports none (failed or cut short).
    """
    times = [float(match["seconds"]) for line in unwrap(log)
             if (match := _SECONDS.match(line))]
    return sum(times) if times else None


_RADIOSITY_SAMPLES = re.compile(r"^\s*Radiosity samples calculated:\s*(?P<count>\d+)")
_RADIOSITY_TIME = re.compile(r"^\s*Radiosity Time:.*\((?P<seconds>\d+(?:\.\d+)?) seconds\)")
_RADIOSITY_SECONDS = re.compile(r"Radiosity Time:[^\n]*seconds")


def parse_radiosity(log: str) -> tuple[int, float] | None:
    """The radiosity samples POV-Ray computed (pretrace and final render) and the seconds of its
    pretrace, summed over every frame of the log; None if it reports no radiosity statistics."""
    if "Radiosity samples calculated" not in log and not _RADIOSITY_SECONDS.search(log):
        return None  # without radiosity ("Radiosity Time: No radiosity"): no log of many frames to unwrap (0.1 s)
    lines = unwrap(log)
    counts = [int(m["count"]) for line in lines if (m := _RADIOSITY_SAMPLES.match(line))]
    seconds = [float(m["seconds"]) for line in lines if (m := _RADIOSITY_TIME.match(line))]
    return (sum(counts), sum(seconds)) if counts or seconds else None


_PHOTONS_SHOT = re.compile(r"^\s*Number of photons shot:\s*(?P<count>\d+)")
_PHOTON_SECONDS = re.compile(r"Photon Time:[^\n]*seconds")   # not "Photon Time: No photons"


def parse_photons(log: str) -> int | None:
    """The photons POV-Ray shot, summed over every frame of the log (a frame that loads its map shoots
    none); None if no frame reports photon statistics."""
    if not _PHOTON_SECONDS.search(log):
        return None
    return sum(int(m["count"]) for line in unwrap(log) if (m := _PHOTONS_SHOT.match(line)))


def parse_progress(text: str, frame: int = 1, share: float = 0.0) -> tuple[int, float]:
    """Where a verbose (``+V``) POV-Ray run is, after reading `text` of its log.

    Parameters
    ----------
    text : str
        Whole lines of the log, read since the state (`frame`, `share`) was taken.
    frame : int
        The frame being rendered, 1-based (1 for a still).
    share : float
        Share of that frame's pixels reported rendered, in ``[0, 1]``.

    Returns
    -------
    (frame, share) : (int, float)
        The state after `text`: ``frame - 1 + share`` frames are rendered.
    """
    for match in _PROGRESS.finditer(text):
        if match["frame"] is not None:
            new = int(match["frame"])
            if new != frame:  # POV-Ray prints the frame line twice
                frame, share = new, 0.0
        elif int(match["total"]) > 0:
            share = min(1.0, int(match["done"]) / int(match["total"]))
    return frame, share


def _messages(log: str) -> list[str]:
    """The log's lines without the verbose per-block progress lines."""
    return [line for line in log.splitlines() if not _PIXEL_LINE.match(line.strip())]


def describe_exit(code: int, log: str) -> str:
    if code < 0:
        return f"POV-Ray was killed by signal {-code}"
    last = next((line.strip() for line in reversed(_messages(log)) if line.strip()), "")
    return f"POV-Ray exited with code {code}" + (f": {last}" if last else "")


def tail(log: str, lines: int = 40) -> str:
    """The last ``lines`` lines of a POV-Ray log (what an error carries)."""
    return "\n".join(_messages(log)[-lines:])


_INCLUDE_NAME = re.compile(r"Cannot open include file (.+?)\.?\s*$", re.M)


#: POV-Ray 3.7's warning where it turns a non-ASCII character of a string into a space.
NON_ASCII_WARNING = "Non-ASCII character has been replaced"


def denied_note(reason: str, include_dirs: tuple[str, ...], log: str = "", confined: bool = True) -> str:
    """What to add to a "cannot open" error: POV-Ray's ASCII file names when it replaced
    non-ASCII characters; that the file is not there; else, when `confined`, the sandbox
    note (the file exists, so the sandbox refused it)."""
    from ..errors import param   # here: log.py stays a leaf of the import graph

    if _replaced_non_ascii(reason, log):
        return (" (POV-Ray 3.7 reads the file names written in a scene as ASCII and turned each non-ASCII "
                "character into a space; povh3d bridges that for names relative to the scene's folder or an "
                f"{param('include_dirs')} folder, not for absolute names, names with '..' or names computed while parsing: "
                "rename the file and its folders with ASCII characters only)")
    match = _INCLUDE_NAME.search(reason)
    if match:
        name = match[1].strip()
        if not any(os.path.exists(os.path.join(d, name)) for d in (*include_dirs, ".")):
            return (f" ({name} is neither beside the scene nor in an {param('include_dirs')} folder; check the name, "
                    f"or add its folder with {param('include_dirs')})")
    if not confined:
        return ""
    return (" (povh3d lets a scene read only its own files and POV-Ray's include files, "
            "and write only in its job folder)")


def _replaced_non_ascii(reason: str, log: str) -> bool:
    """Whether POV-Ray replaced a non-ASCII character on the line that the error `reason` names."""
    where = reason.split(": ", 1)[0]
    for line in unwrap(log):
        match = _LOCATION.match(line.strip())
        if match and NON_ASCII_WARNING in match["message"] and f"{match['file']} line {match['line']}" == where:
            return True
    return False


def past_scene_end(message: str, scene_name: str, script_name: str = "scene.pov") -> str:
    """`message` with a location in povh3d's own script (`script_name`, which includes the
    user's scene) said as what it means: POV-Ray read on past the end of `scene_name`,
    so the cause is most likely there (an unclosed brace, a missing ';')."""
    said = (f"POV-Ray read past the end of {scene_name} into povh3d's own script, so look at the end "
            f"of {scene_name} (an unclosed brace, a missing ';'): ")
    # A function, not a template: a name with a backslash (``a\\b.pov``) is text, not an escape.
    return re.sub(rf"(?<=: ){re.escape(script_name)} line \d+: ", lambda _: said, message, count=1)
