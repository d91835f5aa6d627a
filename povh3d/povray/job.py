"""One POV-Ray run described: the job (scene, size, switches), its result, its
command line and the ``povray.conf`` that confines its file access.  Pure: the
process itself is ``process.run_jobs``'s."""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from ..errors import ConfigError

SCENE_FILE = "scene.pov"
LOG_FILE = "povray.log"
#: Output name: ``frame.ppm``, or ``frame1.ppm``... for an animation, where
#: POV-Ray pads the number to the width of the last one (frame01..frame12);
#: ``frame.png``... for a job that asks for alpha (``PovrayJob.image_suffix``).
OUTPUT_STEM = "frame"
_FRAME_NAME = re.compile(rf"{OUTPUT_STEM}(\d+)\.(?:ppm|png)")


@dataclass(frozen=True)
class ClockRun:
    """Where a job sits in a POV-Ray animation of frames ``1..total`` whose clock runs
    ``clock_start..clock_end``: its first frame's number (``+SF``)."""

    first: int
    total: int
    clock_start: float
    clock_end: float


@dataclass(frozen=True)
class PovrayJob:
    """One POV-Ray run: a scene, its size and switches.

    Parameters
    ----------
    name : str
        Shown in progress and errors, e.g. ``"view 3,5"``.
    script : str
        The complete ``.pov`` text.
    width, height : int
        Image size, pixels.
    frames : int
        Above 1, an animation: ``frame_number`` runs 1..frames, one image each.
    clock_run : ClockRun or None
        The job is frames ``first..first + frames - 1`` of a longer POV-Ray animation
        (``+KFI1 +KFF total +KI +KF``, rendered as the subset ``+SF/+EF``), so each
        frame's ``clock`` is the value POV-Ray gives it in the whole animation.
    include_dirs : tuple of str
        Library folders (``+L``), the scene's own folder first; POV-Ray may
        read anything below them.  Relative paths are taken from the caller's
        working folder.
    options : tuple of str
        Extra switches, appended last, e.g. ``("+A0.3", "+R3")``.
    threads : int or None
        Render threads (``+WT``); None for POV-Ray's default.
    bit_depth : {8, 16}
        Bits per channel of the images.
    file_gamma : str
        ``File_Gamma`` of the output, e.g. ``"sRGB"`` or ``"1.0"``.
    timeout : float or None
        Seconds this job may take.
    start_row, end_row : int or None
        Render only rows ``start_row <= row < end_row`` (0-based); the image
        keeps its full size and the other rows are black.
    read_files : tuple of str or None
        The files the scene may read (the sandbox's allow-list), besides
        POV-Ray's own; None allows everything below `include_dirs`.
    links : tuple of (str, str)
        ``(name, file)``: a link ``name`` (relative) in the job's folder, POV-Ray's
        working folder, to ``file``: how a scene reaches a file it names with
        non-ASCII characters (``scene.Scene.ascii_names``).
    keep_files : tuple of (str, str)
        ``(name, destination)``: a file the job writes in its folder (a radiosity solution
        it saves for later runs) moved to ``destination`` once the job succeeds.
    """

    name: str
    script: str
    width: int
    height: int
    frames: int = 1
    include_dirs: tuple[str, ...] = ()
    options: tuple[str, ...] = ()
    threads: int | None = None
    bit_depth: int = 8
    file_gamma: str = "sRGB"
    timeout: float | None = None
    start_row: int | None = None
    end_row: int | None = None
    read_files: tuple[str, ...] | None = None
    links: tuple[tuple[str, str], ...] = ()
    clock_run: ClockRun | None = None
    keep_files: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        if self.read_files is not None:
            if isinstance(self.read_files, (str, bytes)):
                self._reject("read_files", "must be a sequence of paths", self.read_files)
            object.__setattr__(self, "read_files",
                               tuple(os.path.abspath(p) for p in self.read_files))
        for name in ("include_dirs", "options"):
            value = getattr(self, name)
            if isinstance(value, (str, bytes)):
                self._reject(name, "must be a sequence of strings", value)
            # Lists are accepted for convenience; stored as tuples to stay hashable.
            object.__setattr__(self, name, tuple(str(item) for item in value))
        for field_name in ("links", "keep_files"):
            pairs = tuple((str(name), str(file)) for name, file in getattr(self, field_name))
            object.__setattr__(self, field_name, pairs)
            for name, _ in pairs:  # a link, a kept file: inside the job folder
                if not name or os.path.isabs(name) or ".." in Path(name).parts:
                    self._reject(field_name, "must name paths inside the job folder", name)
        for name in ("width", "height", "frames"):
            self._check_positive(name, getattr(self, name))
        if self.threads is not None:
            self._check_positive("threads", self.threads)
        if self.bit_depth not in (8, 16):
            self._reject("bit_depth", "must be 8 or 16", self.bit_depth)
        if not self.file_gamma or any(c.isspace() for c in self.file_gamma):
            self._reject("file_gamma", "must be a word such as 'sRGB' or '1.0'",
                         self.file_gamma)
        if self.timeout is not None and not self.timeout > 0:
            self._reject("timeout", "must be positive seconds or None", self.timeout)
        self._check_rows()
        run = self.clock_run
        if run is not None and not (1 <= run.first and run.first + self.frames - 1 <= run.total):
            self._reject("clock_run", f"must hold its {self.frames} frames within 1..total", run)

    @property
    def frame_numbers(self) -> range:
        """POV-Ray's numbers of the job's frames (1..frames, or a clock run's subset)."""
        first = 1 if self.clock_run is None else self.clock_run.first
        return range(first, first + self.frames)

    @property
    def image_suffix(self) -> str:
        """How POV-Ray writes the job's images: ``".ppm"`` (binary P6, uncompressed: POV-Ray
        deflating a PNG and povh3d inflating it again cost about 20 ms of CPU a frame), or
        ``".png"`` for a job that asks for alpha (``+UA``), which a PPM cannot hold."""
        return ".png" if any(o.upper().startswith("+UA") for o in self.options) else ".ppm"

    @property
    def rows(self) -> tuple[int, int] | None:
        """``(start, end)`` rows to render, 0-based, end exclusive; None for all."""
        if self.start_row is None and self.end_row is None:
            return None
        start = 0 if self.start_row is None else self.start_row
        return start, self.height if self.end_row is None else self.end_row

    def _check_rows(self) -> None:
        rows = self.rows
        if rows is not None and not 0 <= rows[0] < rows[1] <= self.height:
            self._reject("start_row, end_row",
                         f"must satisfy 0 <= start_row < end_row <= height ({self.height})",
                         rows)

    def _check_positive(self, name: str, value: object) -> None:
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            self._reject(name, "must be a positive integer", value)

    def _reject(self, name: str, rule: str, value: object) -> None:
        raise ConfigError(f"POV-Ray job {self.name!r}: {name} {rule}, got {value!r}.")


@dataclass(frozen=True)
class JobResult:
    """A finished job, handed to ``on_result`` while its folder exists.

    Parameters
    ----------
    job : PovrayJob
    images : tuple of Path
        One image per frame (``PovrayJob.image_suffix``: PPM, or PNG with alpha), in frame
        order; deleted after ``on_result`` returns.  ``image.io.read_image`` reads either.
    seconds : float
        Wall time of the POV-Ray process, s.
    log : str
        POV-Ray's console output (stdout and stderr).
    """

    job: PovrayJob
    images: tuple[Path, ...]
    seconds: float
    log: str


def _image_buffer_mb(job: PovrayJob) -> int:
    """Memory for POV-Ray's image buffer, MB (``+MI``, default 128).

    Past it POV-Ray 3.7 backs the image with a file at the hard-wired path
    ``/tmp/pov<pid>`` (not TMPDIR), outside the job folder: the sandbox refuses
    it, and a crash would leave it behind.  It keeps about 5 floats a pixel;
    give it twice that.
    """
    return max(128, -(-2 * 20 * job.width * job.height // (1 << 20)))


def build_command(job: PovrayJob, binary: str) -> list[str]:
    """Command line that renders `job` in its folder.

    Paths of the scene and images are relative: the child runs in the job's
    folder.  Include folders are made absolute here, from the caller's
    working folder.
    """
    # +V: POV-Ray logs "Rendered N of M pixels" as it goes, which the progress display reads.
    kind = "N" if job.image_suffix == ".png" else "P"  # +FN PNG, +FP PPM
    command = [binary, f"+I{SCENE_FILE}", f"+O{OUTPUT_STEM}{job.image_suffix}",
               f"+W{job.width}", f"+H{job.height}", f"+F{kind}{job.bit_depth}",
               f"File_Gamma={job.file_gamma}", "-D", "+V", f"+MI{_image_buffer_mb(job)}"]
    # Unquoted, POV-Ray rejects a library path holding a space.
    command += [f"+L{_quote(os.path.abspath(folder))}" for folder in job.include_dirs]
    if job.threads is not None:
        command.append(f"+WT{job.threads}")
    run = job.clock_run
    if run is not None:
        # POV-Ray's own clock for frames first..last of the whole animation: the same
        # value, bit for bit, as a still rendered with +K at that frame's clock.
        command += ["+KFI1", f"+KFF{run.total}", f"+KI{run.clock_start!r}", f"+KF{run.clock_end!r}",
                    f"+SF{run.first}", f"+EF{run.first + job.frames - 1}"]
    elif job.frames > 1:
        # Frames here are shots of one still (views, lenses, depth passes), not an animation: the
        # clock stays a still's (0) in each; POV-Ray's default runs it 0..1 over the frames, which a
        # scene reading `clock` would see.  A set clock (RenderSettings.options) comes later and wins.
        command += ["+KFI1", f"+KFF{job.frames}", "+KI0", "+KF0"]
    if job.rows is not None:
        # POV-Ray reads a row of 1 or less as a fraction of the height (+ER1
        # means the last row); "n.5" is above 1 and truncates to row n.
        start, end = job.rows
        command += [f"+SR{start + 1}.5", f"+ER{end}.5"]
    return command + list(job.options)


def povray_conf(read_dirs: Sequence[str], write_dir: str) -> str:
    """Text of a user ``povray.conf`` for one job.

    Parameters
    ----------
    read_dirs : sequence of str
        Absolute folders POV-Ray may read, with everything below them.
    write_dir : str
        The job's folder, where it may also write.
    """
    lines = ["; Written by povh3d for one render; deleted with it.",
             "[File I/O Security]", "restricted",
             "[Shellout Security]", "forbidden",
             "[Permitted Paths]",
             # A user conf replaces the system's paths, so list those again.
             'read* = "%INSTALLDIR%/include"', 'read* = "/etc/povray"']
    lines += [f"read* = {_quote(folder)}" for folder in read_dirs]
    lines += [f"read+write* = {_quote(write_dir)}", "read+write = ."]
    return "\n".join(lines) + "\n"


def _quote(path: str) -> str:
    """`path` in the quotes POV-Ray accepts on its command line and in its conf."""
    if '"' not in path:
        return f'"{path}"'
    if "'" not in path:
        return f"'{path}'"
    raise ConfigError(f"POV-Ray cannot take a folder whose name holds both "
                      f"quote characters: {path!r}.")


def collect_images(folder: Path, job: PovrayJob) -> tuple[Path, ...] | None:
    """The output images in frame order, or None unless all are there."""
    if job.frames == 1 and job.clock_run is None:
        path = folder / f"{OUTPUT_STEM}{job.image_suffix}"
        return (path,) if path.is_file() else None
    numbered = {int(match[1]): path for path in folder.glob(f"{OUTPUT_STEM}*{job.image_suffix}")
                if (match := _FRAME_NAME.fullmatch(path.name))}
    if sorted(numbered) != list(job.frame_numbers):
        return None
    return tuple(numbered[number] for number in job.frame_numbers)


def frame_image(folder: Path, job: PovrayJob, number: int) -> Path:
    """Where POV-Ray writes frame `number` (1-based, of the job's own frames) of `job`."""
    if job.frames == 1 and job.clock_run is None:
        return folder / f"{OUTPUT_STEM}{job.image_suffix}"
    # POV-Ray pads the number to the width of the animation's last one.
    total = job.frames if job.clock_run is None else job.clock_run.total
    return folder / f"{OUTPUT_STEM}{job.frame_numbers[number - 1]:0{len(str(total))}d}{job.image_suffix}"


def expected_images(job: PovrayJob) -> str:
    if job.frames == 1 and job.clock_run is None:
        return f"{OUTPUT_STEM}{job.image_suffix}"
    first, last = frame_image(Path(), job, 1), frame_image(Path(), job, job.frames)
    return f"the {job.frames} frames {first}..{last}"


_LITERAL = re.compile(r'"([^"\n]*[^\x00-\x7f][^"\n]*)"')


def ascii_paths(job: PovrayJob, folder: Path) -> PovrayJob:
    """`job` with every non-ASCII path replaced by an ASCII symlink in its `folder`.

    POV-Ray 3.7 reads strings in scripts and on its command line as ASCII and
    replaces other characters by spaces ("Cannot open include file .../T  l");
    a link named ``povh3d-link-N`` in the job folder reaches the same file.  The
    scene's own non-ASCII names get links under the names POV-Ray will ask for
    (`job.links`): the job folder is its working folder, searched first.  The
    sandbox and POV-Ray's own I/O rules still apply: the links sit in the job
    folder and resolve to the files the job may read.
    """
    for name, target in job.links:
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        os.symlink(target, folder / name)
    links: dict[str, str] = {}

    def alias(path: str) -> str:
        if path not in links:
            link = folder / f"povh3d-link-{len(links)}{Path(path).suffix if os.path.isfile(path) else ''}"
            os.symlink(path, link)
            links[path] = str(link)
        return links[path]

    dirs = tuple(alias(os.path.abspath(d)) if not d.isascii() and os.path.isdir(d) else d
                 for d in job.include_dirs)
    script = _LITERAL.sub(lambda m: f'"{alias(m[1])}"' if os.path.exists(m[1]) else m[0], job.script)
    if not links:
        return job
    return replace(job, include_dirs=dirs, script=script)


def original_names(text: str, folder: Path) -> str:
    """`text` (an error) with the links `ascii_paths` made in `folder` named by what they stand for."""
    for link in folder.glob("povh3d-link-*"):
        text = text.replace(str(link), os.readlink(link))
    return text
