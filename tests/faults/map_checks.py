"""What a map folder holds, read with plain file access, for the fault and reader tests (issue 21).

A checkpoint is committed when the manifest naming it (`config checkpoint K`) is renamed into place;
its keyframe list and run state follow under their final names. The tests compare a folder against
the commits a run made (copies the preloaded library keeps, see fault_inject.c), by content: chunk
generations differ between runs, a chunk's count, size and checksum do not (the runs are made
deterministic with one thread per stage).
"""

import re
from pathlib import Path


def read_manifest(path):
    """(checkpoint number or 0, {chunk id: (count, bytes, checksum)}, {chunk id: generation})."""
    checkpoint, chunks, generations = 0, {}, {}
    for line in Path(path).read_text().splitlines():
        f = line.split()
        if len(f) == 3 and f[0] == "config" and f[1] == "checkpoint":
            checkpoint = int(f[2])
        elif len(f) == 6 and f[0] == "chunk":
            chunks[f[1]] = (int(f[2]), int(f[3]), f[4])
            generations[f[1]] = int(f[5])
    return checkpoint, chunks, generations


def keyframe_ids(text):
    return [int(line.split()[0]) for line in text.splitlines() if line.strip() and not line.startswith("#")]


class Commits:
    """The commits one run made, in order, from the copies in its keep folder."""

    def __init__(self, keep_dir):
        self.chunks = {}  # checkpoint -> chunk contents its manifest names
        self.keyframes = {}  # checkpoint -> keyframes.txt as committed with it
        self.run_state = {}
        self.order = []  # checkpoint numbers in commit order
        current = None
        for f in sorted(Path(keep_dir).iterdir()):
            name = f.name.split("-", 1)[1]
            if name == "manifest.txt":
                current, chunks, _ = read_manifest(f)
                self.chunks[current] = chunks
                self.order.append(current)
            elif name == "keyframes.txt" and current is not None:
                self.keyframes[current] = f.read_text()
            elif name == "run_state.json" and current is not None:
                self.run_state[current] = f.read_text()

    def last(self):
        return self.order[-1] if self.order else None


FAR_LEVEL_BIT = 1 << 63


def exported_total(chunks):
    """The Gaussians `export` writes for a manifest's chunks: each 10 m cube once, its near level, or its
    far level (id with the top bit set) where the map has no near level for that cube."""
    ids = {int(name, 16) for name in chunks}
    return sum(c[0] for name, c in chunks.items()
               if not (int(name, 16) & FAR_LEVEL_BIT and int(name, 16) & ~FAR_LEVEL_BIT in ids))


PLY_COUNT = re.compile(rb"element vertex (\d+)")


def ply_count(path):
    with open(path, "rb") as f:
        head = f.read(4096)
    m = PLY_COUNT.search(head)
    return int(m.group(1)) if m else None


def check_committed(folder, own, reference):
    """Problems with `folder` after a failed run: its manifest must be the last one the run itself
    committed (`own`), holding what the reference run committed at that checkpoint, its chunk files
    present, and its keyframe list that checkpoint's (or the one before with the checkpoint's own
    list waiting under its numbered name, which opening for --resume puts in place)."""
    folder = Path(folder)
    problems = []
    manifest = folder / "manifest.txt"
    if not manifest.exists():
        if own.last() is not None:
            problems.append(f"manifest.txt gone though checkpoint {own.last()} was committed")
        return problems, None
    k, chunks, generations = read_manifest(manifest)
    if own.last() is not None and k != own.last():
        problems.append(f"manifest names checkpoint {k}, the run last committed {own.last()}")
    if k in reference.chunks and chunks != reference.chunks[k]:
        diff = sorted(set(chunks.items()) ^ set(reference.chunks[k].items()))[:3]
        problems.append(f"checkpoint {k}: chunks differ from the reference run's: {diff}")
    for cid, g in generations.items():
        if not (folder / "chunks" / f"{cid}-{g:016x}.chunk").is_file():
            problems.append(f"chunk {cid} generation {g} named by the manifest is missing")
    if k > 0:
        listed = folder / "keyframes.txt"
        pending = folder / f"checkpoint-{k}-keyframes.txt"
        text = listed.read_text() if listed.exists() else None
        if text != reference.keyframes.get(k):
            if not (pending.exists() and pending.read_text() == reference.keyframes.get(k)):
                problems.append(f"keyframes.txt is not checkpoint {k}'s and no pending copy of it exists")
            text = pending.read_text() if pending.exists() else text
        for kid in keyframe_ids(text or ""):
            if not (folder / "keyframes" / f"{kid}.keyframe").is_file():
                problems.append(f"keyframe {kid} listed by checkpoint {k} has no file")
    return problems, k
