#!/usr/bin/python3
"""CTest regression.Tutorial.CommandsRun: docs/guide/tutorial.md cannot rot.

  run_tutorial.py PERISTAT SOURCE_DIR WORK_DIR

1. The scene. The tutorial's ```yaml scene blocks, joined in order, must be
   cases/tutorial_closed_flaw/scene.yaml byte for byte. They are written to
   WORK_DIR/closed_flaw.yaml, the file the reader types.
2. The commands. Every ```sh block runs with bash (set -euo pipefail) in WORK_DIR, in the
   tutorial's order. build/peristat there is PERISTAT, the program under test. scripts/ and
   cases/ are the source tree's. Everything runs on one thread (OMP_NUM_THREADS=1).
   A ```sh slow block holds a measured study that takes minutes, so it is not run. Each
   `build/peristat run SCENE ... --set K=V` in it is checked with
   `build/peristat check SCENE --set K=V` instead, so its keys and values stay valid.
3. The outputs. After a block has run, every `--out DIR` of a `peristat run` in it must hold
   summary.json with status "completed" and the .h5 and .xdmf files it names. Every .png the
   block's commands name must exist.
4. The figures. Every image the tutorial shows (![...](...)) must exist in the source tree.

Exit 0 when everything passes. Otherwise exit 1, naming the failing block by its line in
the tutorial and printing its output.
"""

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import time

TUTORIAL = "docs/guide/tutorial.md"
CASE = "cases/tutorial_closed_flaw/scene.yaml"
SCENE_FILE = "closed_flaw.yaml"
FENCE = re.compile(r"^```(\S*)[ \t]*(.*)$")


def blocks(text):
    """(info words, first line number, body) of every fenced block, in order."""
    found, lines, i = [], text.split("\n"), 0
    while i < len(lines):
        match = FENCE.match(lines[i])
        if match and match.group(1):
            start, body = i + 1, []
            i += 1
            while i < len(lines) and lines[i] != "```":
                body.append(lines[i])
                i += 1
            if i == len(lines):
                sys.exit("%s:%d: unclosed code block" % (TUTORIAL, start))
            found.append(([match.group(1)] + match.group(2).split(), start, "\n".join(body) + "\n"))
        i += 1
    return found


def commands(body):
    """The block's commands: continuation lines joined, comments and blank lines dropped."""
    joined = re.sub(r"\\\n", " ", body)
    return [line.strip() for line in joined.split("\n") if line.strip() and not line.strip().startswith("#")]


def check_outputs(command, where, failures):
    words = shlex.split(command, comments=True)
    for word in words:
        if word.endswith(".png") and not os.path.isfile(word):
            failures.append("%s: %s was not written" % (where, word))
    if len(words) >= 2 and words[0] == "build/peristat" and words[1] == "run" and "--out" in words:
        out = words[words.index("--out") + 1]
        try:
            with open(os.path.join(out, "summary.json")) as handle:
                summary = json.load(handle)
        except (OSError, ValueError) as error:
            failures.append("%s: %s/summary.json: %s" % (where, out, error))
            return
        if summary.get("status") != "completed":
            failures.append("%s: %s ended with status %s: %s" % (where, out, summary.get("status"), summary.get("message")))
        for ext in (".h5", ".xdmf"):
            path = os.path.join(out, summary.get("scene", "?") + ext)
            if not os.path.isfile(path):
                failures.append("%s: %s was not written" % (where, path))


def check_only(command):
    """`build/peristat check SCENE --set ...` for a `build/peristat run SCENE ...` line, else None."""
    words = shlex.split(command, comments=True)
    if len(words) < 3 or words[0] != "build/peristat" or words[1] != "run":
        return None
    checked = ["build/peristat", "check", words[2]]
    for k, word in enumerate(words):
        if word == "--set":
            checked += ["--set", words[k + 1]]
    return checked


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    peristat, source, work = (os.path.abspath(a) for a in sys.argv[1:])
    if not os.access(peristat, os.X_OK):
        sys.exit("run_tutorial: %s is not an executable" % peristat)
    with open(os.path.join(source, TUTORIAL)) as handle:
        text = handle.read()
    found = blocks(text)
    failures = []

    # 1. The scene shown is the case's scene.
    scene = "".join(body for info, _, body in found if info[:2] == ["yaml", "scene"])
    with open(os.path.join(source, CASE)) as handle:
        case = handle.read()
    if scene != case:
        diff = subprocess.run(["diff", "-u", "--label", CASE, "--label", TUTORIAL + " (```yaml scene blocks)",
                               os.path.join(source, CASE), "-"], input=scene, capture_output=True, text=True)
        print(diff.stdout)
        failures.append("the ```yaml scene blocks of %s, joined, differ from %s (diff above)" % (TUTORIAL, CASE))

    # 4. The figures it shows exist.
    for image in re.findall(r"!\[[^\]]*\]\(([^)\s]+)\)", text):
        path = os.path.normpath(os.path.join(source, os.path.dirname(TUTORIAL), image))
        if not os.path.isfile(path):
            failures.append("%s shows %s, which does not exist" % (TUTORIAL, image))

    # 2. and 3. The commands run, in a fresh folder laid out like the repository.
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(os.path.join(work, "build"))
    os.symlink(peristat, os.path.join(work, "build", "peristat"))
    for tree in ("scripts", "cases"):
        os.symlink(os.path.join(source, tree), os.path.join(work, tree))
    with open(os.path.join(work, SCENE_FILE), "w") as handle:
        handle.write(scene)
    os.chdir(work)
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    started = time.monotonic()
    for info, line, body in found:
        if info[0] != "sh":
            continue
        where = "%s:%d" % (TUTORIAL, line)
        tick = time.monotonic()
        if "slow" in info[1:]:
            for command in commands(body):
                checked = check_only(command)
                if checked is None:
                    continue
                result = subprocess.run(checked, capture_output=True, text=True, env=env)
                if result.returncode != 0:
                    failures.append("%s: `%s` failed (exit %d): %s" % (where, " ".join(checked), result.returncode,
                                                                        result.stderr.strip()))
            print("%s: slow block, its runs checked (%.1f s)" % (where, time.monotonic() - tick), flush=True)
            continue
        result = subprocess.run(["bash", "-euo", "pipefail", "-c", body], capture_output=True, text=True, env=env)
        print("%s: exit %d (%.1f s)" % (where, result.returncode, time.monotonic() - tick), flush=True)
        if result.returncode != 0:
            print(body + "--- stdout\n" + result.stdout[-4000:] + "--- stderr\n" + result.stderr[-4000:])
            failures.append("%s: the block failed with exit %d (output above)" % (where, result.returncode))
            break  # later blocks use this one's results
        for command in commands(body):
            check_outputs(command, where, failures)
    print("commands: %.1f s" % (time.monotonic() - started))

    for failure in failures:
        print("FAIL " + failure)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
