"""Moving a finished attempt's outputs from its staging folder to their final names (client side).

Staging folders live under OUT/.texdefrag-batch/staging/, on the output's file system, so every
move is one rename(2): a file under a final name is always complete. Order: the images and other
files first, then the model file (its name is the input's stem: <stem>.obj, .osgb...), which
references them, then <stem>.report.json last. So a model under its final name always has its
pages and MTL in place, and the report's presence means the task's set is complete. The journal
marks the task finished only after the last rename; a crash in between leaves the task "running"
and the next batch redoes it. Files of the task's previous output that the new one no longer has
(fewer pages) are removed after the journal records the new set.
"""

import os
import shutil


def order(files, stem):
    """The staging files in commit order (see above)."""
    report = f"{stem}.report.json"

    def rank(name):
        if name == report:
            return 2
        base, ext = os.path.splitext(name)
        return 1 if base == stem and ext.lower() not in (".mtl",) else 0

    return sorted(files, key=lambda n: (rank(n), n))


def commit(staging, files, output_root, output_dir, stem):
    """Renames staging/out/<file> to output_root/output_dir/<file> in commit order (files may be
    relative paths with folders); returns the outputs' paths relative to output_root. Raises
    OSError naming the file on failure."""
    src_dir = os.path.join(staging, "out")
    dst_dir = os.path.normpath(os.path.join(output_root, output_dir))
    os.makedirs(dst_dir, exist_ok=True)
    outputs = []
    for name in order(files, stem):
        src, dst = os.path.join(src_dir, name), os.path.join(dst_dir, name)
        if "/" in name:
            os.makedirs(os.path.dirname(dst), exist_ok=True)
        try:
            os.replace(src, dst)
        except OSError as e:
            raise OSError(f"cannot move {src} to {dst}: {e.strerror}") from None
        outputs.append(os.path.relpath(dst, output_root))
    _fsync_dir(dst_dir)
    return outputs


def remove_stale(output_root, old_outputs, new_outputs):
    """Removes files of a previous output set that the new set does not contain."""
    keep = set(new_outputs)
    for rel in old_outputs or []:
        if rel not in keep:
            try:
                os.remove(os.path.join(output_root, rel))
            except FileNotFoundError:
                pass


def _fsync_dir(path):
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def same_file(a, b):
    """True when b exists with a's size and bytes."""
    try:
        if os.path.getsize(a) != os.path.getsize(b):
            return False
    except OSError:
        return False
    with open(a, "rb") as fa, open(b, "rb") as fb:
        while True:
            x, y = fa.read(1 << 20), fb.read(1 << 20)
            if x != y:
                return False
            if not x:
                return True


def copy_through(src, output_root, rel):
    """Copies a pass-through file (a production's metadata.xml) to output_root/rel under a temporary
    name, then renames it; nothing when the copy is already identical. Returns True when copied.
    Raises OSError naming both files."""
    dst = os.path.join(output_root, rel)
    if same_file(src, dst):
        return False
    os.makedirs(os.path.dirname(dst), exist_ok=True)
    tmp = os.path.join(os.path.dirname(dst), f".{os.path.basename(dst)}.texdefrag-batch.tmp")
    try:
        shutil.copyfile(src, tmp)
        os.replace(tmp, dst)
    except OSError as e:
        try:
            os.remove(tmp)
        except OSError:
            pass
        raise OSError(f"cannot copy {src} to {dst}: {e.strerror or e}") from None
    return True


def clear_staging(staging_root):
    """Removes every staging folder (the start and end of a batch: no attempt is running)."""
    if os.path.isdir(staging_root):
        for name in os.listdir(staging_root):
            shutil.rmtree(os.path.join(staging_root, name), ignore_errors=True)
