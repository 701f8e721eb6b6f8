"""Stand-in for the Blender binary on machines that only have the ``bpy`` module.

``scripts/blender`` runs this file. It accepts the subset of Blender's own command line that batch
jobs use, processed left to right as Blender does::

    scripts/blender -b scene.blend --python script.py -- --script-args ...
    scripts/blender -b scene.blend -E CYCLES -o //render_#### -f 1
    scripts/blender -b --python-expr "import bpy; print(bpy.app.version_string)"
    scripts/blender -t 4 -b scene.blend --python script.py     # 4 threads for Illumap's core

so that tests and the README exercise batch jobs exactly as users type them with a real
``blender`` executable. It is not Blender: there is no UI, and options outside this subset are
refused with exit code 2 rather than ignored.

Exit codes follow Blender: 0 at the end of the arguments; ``sys.exit(n)`` inside a script exits
with n; an exception in a script exits with the value of ``--python-exit-code`` (default 0, as in
Blender, which only prints the traceback). A ``.blend`` that exists but cannot be read (corrupt,
truncated) stops the arguments there, as in Blender, with one line naming the file and exit code
3, the batch's "bad scene or input" (a Blender binary stops there too, with its own message and
non-zero exit code).
"""

from __future__ import annotations

import os
import runpy
import sys
import traceback

USAGE = __doc__


def _fail(message: str) -> "NoReturn":  # noqa: F821
    print(f"blender (bpy launcher): {message}", file=sys.stderr)
    raise SystemExit(2)


#: Exit code for a .blend that cannot be read (corrupt, truncated, not a .blend): the batch's
#: "bad scene or input" (addon/errors.py, ExitCode.INPUT).
UNREADABLE_FILE = 3


def _unreadable(path: str, exc: BaseException) -> "NoReturn":  # noqa: F821
    """A .blend that exists but cannot be read. Blender stops processing its arguments there
    in the background, so no script runs on a scene that is not there; the launcher says so
    in one line and exits with ``UNREADABLE_FILE`` (Blender's own message is printed above)."""
    reason = " ".join(str(exc).split())
    reason = reason[len("Error:"):].strip() if reason.startswith("Error:") else reason
    print(f"blender (bpy launcher): cannot read {path}: not a readable .blend file ({reason})",
          file=sys.stderr)
    raise SystemExit(UNREADABLE_FILE)


def _run_python(run, exit_code_on_error: int) -> None:
    try:
        run()
    except SystemExit:
        raise
    except BaseException:  # Blender prints the traceback and carries on
        traceback.print_exc()
        if exit_code_on_error:
            raise SystemExit(exit_code_on_error)


def main(argv: list[str]) -> int:
    """Processes Blender command-line arguments in order; returns the exit code."""
    if "--" in argv:
        split = argv.index("--")
        own, _script_args = argv[:split], argv[split + 1:]
    else:
        own, _script_args = argv, []
    if "-h" in own or "--help" in own:
        print(USAGE)
        return 0

    import bpy  # imported late so --help works without it

    # Blender scripts read their own arguments from sys.argv after "--".
    sys.argv = ["blender", *argv]
    exit_code_on_error = 0
    i = 0

    def take() -> str:
        nonlocal i
        if i + 1 >= len(own):
            _fail(f"option {own[i]} needs a value")
        i += 1
        return own[i]

    while i < len(own):
        arg = own[i]
        if arg in ("-b", "--background", "--factory-startup", "-noaudio", "--no-window-focus"):
            pass  # the bpy module is always in the background and starts from factory settings
        elif arg in ("-P", "--python"):
            path = os.path.abspath(take())
            if not os.path.isfile(path):
                _fail(f"no such script: {path}")
            _run_python(lambda: runpy.run_path(path, run_name="__main__"), exit_code_on_error)
        elif arg == "--python-expr":
            expr = take()
            _run_python(lambda: exec(compile(expr, "<string>", "exec"), {"__name__": "__main__"}),
                        exit_code_on_error)
        elif arg == "--python-exit-code":
            exit_code_on_error = int(take())
        elif arg in ("-t", "--threads"):
            # Blender's -t sets its own thread count, which the add-on reads back as
            # scene.render.threads (addon/threads.py); the bpy module has no such override,
            # so the stand-in hands the count to Illumap's core directly (0: all CPUs).
            value = take()
            if not value.isdigit() or int(value) > 1024:
                _fail(f"-t/--threads needs a thread count 0..1024, not {value!r}")
            if int(value):
                os.environ["ILLUMAP_THREADS"] = value
            else:
                os.environ.pop("ILLUMAP_THREADS", None)
        elif arg in ("-E", "--engine"):
            bpy.context.scene.render.engine = take()
        elif arg in ("-o", "--render-output"):
            bpy.context.scene.render.filepath = take()
        elif arg in ("-F", "--render-format"):
            bpy.context.scene.render.image_settings.file_format = take()
        elif arg in ("-s", "--frame-start"):
            bpy.context.scene.frame_start = int(take())
        elif arg in ("-e", "--frame-end"):
            bpy.context.scene.frame_end = int(take())
        elif arg in ("-f", "--render-frame"):
            frame = int(take())
            bpy.context.scene.frame_set(frame)
            bpy.ops.render.render(write_still=True)
        elif arg in ("-a", "--render-anim"):
            bpy.ops.render.render(animation=True)
        elif arg.endswith(".blend") and not arg.startswith("-"):
            path = os.path.abspath(arg)
            if not os.path.isfile(path):
                _fail(f"cannot read file: {path}")
            try:
                bpy.ops.wm.open_mainfile(filepath=path)
            except RuntimeError as exc:
                _unreadable(path, exc)
        else:
            _fail(f"unsupported option {arg!r} (this launcher stands in for Blender; see --help)")
        i += 1
    return 0


if __name__ == "__main__":
    try:
        code = main(sys.argv[1:])
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        if exc.code is not None and not isinstance(exc.code, int):
            print(exc.code, file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    # bpy can hang on interpreter shutdown after a render; Blender itself exits hard too.
    os._exit(code)
