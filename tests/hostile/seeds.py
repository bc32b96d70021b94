"""The small valid inputs every case starts from, made once per run by the CLI itself (synthetic
sequences, a map) and converted by hand into the layouts the CLI cannot write (Replica, 3DMatch,
EuRoC). A case copies the seed it damages, so cases never see each other's damage."""

import math
import shutil
import subprocess
from pathlib import Path

import forge

# Small enough that a case runs in well under a second, large enough for the readers' size floors
# (tracking refuses images below 32x32, mapping below 16x16).
WIDTH, HEIGHT, FRAMES = 64, 48, 8


def _quat_to_matrix(qx, qy, qz, qw):
    n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    x, y, z, w = qx / n, qy / n, qz / n, qw / n
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def _tum_poses(path: Path):
    """(stamp, 4x4 rows) from a TUM trajectory."""
    out = []
    for line in path.read_text().splitlines():
        if not line or line.startswith("#"):
            continue
        t, tx, ty, tz, qx, qy, qz, qw = map(float, line.split())
        r = _quat_to_matrix(qx, qy, qz, qw)
        out.append((t, [r[0] + [tx], r[1] + [ty], r[2] + [tz], [0.0, 0.0, 0.0, 1.0]]))
    return out


def _matrix_line(m):
    return " ".join("%.12g" % v for row in m for v in row)


class Seeds:
    def __init__(self, root: Path, cli: str):
        self.root, self.cli = root, cli

    def __getattr__(self, name):
        return self.root / name

    def _cli(self, *args):
        r = subprocess.run([self.cli, "-q", *args], cwd=self.root, capture_output=True, text=True, check=False)
        if r.returncode != 0:
            raise RuntimeError("seed command failed: diskchungs %s\n%s%s" % (" ".join(args), r.stdout, r.stderr))

    def build(self):
        self.root.mkdir(parents=True, exist_ok=True)
        size = ["--width", str(WIDTH), "--height", str(HEIGHT)]
        self._cli("synth", "room", "--out", "tum", "--frames", str(FRAMES), *size)
        self._cli("synth", "room", "--layout", "kitti", "--out", "kitti", "--frames", str(FRAMES), *size)
        self._cli("synth", "street", "--out", "street", "--frames", "4", "--length-m", "20", *size)
        self._replica()
        self._threedmatch()
        self._euroc()
        # A finished map, and one stopped half-way (the resume point of the --resume cases).
        run = ["run", "--device", "cpu", "--iterations", "1", "--final-iterations", "1"]
        self._cli(*run, "--dataset", "tum:tum", "--out", "map")
        self._cli(*run, "--dataset", "tum:tum", "--out", "map_half", "--max-frames", "4", "--no-eval")
        shutil.copy(self.root / "map" / "trajectory.txt", self.root / "traj_tum.txt")
        shutil.copy(self.root / "kitti" / "poses.txt", self.root / "traj_kitti.txt")
        self._images()

    def copy(self, name: str, dest: Path):
        src = self.root / name
        if src.is_dir():
            shutil.copytree(src, dest, symlinks=True)
        else:
            dest.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(src, dest)

    def _replica(self):
        d = self.root / "replica" / "results"
        d.mkdir(parents=True)
        tum = self.root / "tum"
        lines = []
        for i, (t, m) in enumerate(_tum_poses(tum / "groundtruth.txt")):
            stamp = "%.6f" % t
            shutil.copy(tum / "rgb" / (stamp + ".png"), d / ("frame%06d.png" % i))
            shutil.copy(tum / "depth" / (stamp + ".png"), d / ("depth%06d.png" % i))
            lines.append(_matrix_line(m))
        forge.write(self.root / "replica" / "traj.txt", "\n".join(lines) + "\n")
        forge.write(self.root / "replica" / "cam_params.json",
                    '{"camera": {"w": %d, "h": %d, "fx": 52.5, "fy": 52.5, "cx": 31.5, "cy": 23.5, '
                    '"scale": 5000.0}}\n' % (WIDTH, HEIGHT))

    def _threedmatch(self):
        root = self.root / "3dmatch"
        seq = root / "seq-01"
        seq.mkdir(parents=True)
        tum = self.root / "tum"
        for i, (t, m) in enumerate(_tum_poses(tum / "groundtruth.txt")):
            stamp = "%.6f" % t
            shutil.copy(tum / "rgb" / (stamp + ".png"), seq / ("frame-%06d.color.png" % i))
            shutil.copy(tum / "depth" / (stamp + ".png"), seq / ("frame-%06d.depth.png" % i))
            forge.write(seq / ("frame-%06d.pose.txt" % i), "\n".join(" ".join("%.12g" % v for v in r) for r in m) + "\n")
        forge.write(root / "camera-intrinsics.txt", "52.5 0 31.5\n0 52.5 23.5\n0 0 1\n")

    def _euroc(self):
        root = self.root / "euroc"
        kitti = self.root / "kitti"
        stamps = [1_000_000_000 + 50_000_000 * i for i in range(FRAMES)]
        for cam, folder, tx in (("cam0", "image_2", 0.0), ("cam1", "image_3", 0.1)):
            d = root / "mav0" / cam
            (d / "data").mkdir(parents=True)
            rows = ["#timestamp [ns],filename"]
            for i, ns in enumerate(stamps):
                shutil.copy(kitti / folder / ("%06d.png" % i), d / "data" / ("%d.png" % ns))
                rows.append("%d,%d.png" % (ns, ns))
            forge.write(d / "data.csv", "\n".join(rows) + "\n")
            forge.write(d / "sensor.yaml", (
                "%%YAML:1.0\nsensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n"
                "  data: [1.0, 0.0, 0.0, %g, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]\n"
                "rate_hz: 20\nresolution: [%d, %d]\ncamera_model: pinhole\n"
                "intrinsics: [52.5, 52.5, 31.5, 23.5]\ndistortion_model: radial-tangential\n"
                "distortion_coefficients: [0.0, 0.0, 0.0, 0.0]\n") % (tx, WIDTH, HEIGHT))
        gt = ["# timestamp tx ty tz qx qy qz qw"]
        for ns, line in zip(stamps, (self.root / "tum" / "groundtruth.txt").read_text().splitlines()[1:]):
            gt.append("%.9f %s" % (ns * 1e-9, " ".join(line.split()[1:])))
        forge.write(root / "groundtruth" / "gt.txt", "\n".join(gt) + "\n")

    def _images(self):
        """Reference and test folders for `eval images`: the map's renders against the dataset."""
        ref, test = self.root / "images_ref", self.root / "images_test"
        ref.mkdir()
        test.mkdir()
        for i, name in enumerate(sorted((self.root / "tum" / "rgb").iterdir())[:3]):
            shutil.copy(name, ref / ("%d.png" % i))
            shutil.copy(sorted((self.root / "tum" / "rgb").iterdir())[i + 1], test / ("%d.png" % i))
