#!/usr/bin/python3
"""rosbag: dataset end to end (issue 26).

Writes bags from ../shared/data/kitti_seq1 (stereo, camera_info, ground truth as tf through a camera
mount) and from the synthetic RGB-D room, maps each with `diskchungs run --dataset rosbag:...` and
with the dataset read directly, and requires the held-out PSNR of the two to be within --tolerance.
Then damaged bags (missing topic, wrong message type, truncated file, unsupported encoding, broken
image message, not a bag) must each give one error line naming the bag and the topic or cause, and a
non-zero exit without a crash.

Runs with Debian's python3 (/usr/bin/python3), which has the rosbag module to craft the damaged bags.
Exit 77 (skipped) when the shared data is missing.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

# Small and single-threaded: a CPU run of a few seconds, and bit-identical from run to run (with more
# OpenMP threads, summation order makes two runs of one dataset differ by up to ~0.2 dB).
RUN_ARGS = ["--resolution", "0.25", "--iterations", "5", "--final-iterations", "20", "--device", "cpu",
            "--json"]


def run_map(cli, dataset, out, frames, preset):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    cmd = [cli, "run", "--dataset", dataset, "--out", out, "--max-frames", str(frames), "--preset", preset] + RUN_ARGS
    start = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    if r.returncode != 0:
        sys.exit(f"FAIL: {' '.join(cmd)} exited {r.returncode}: {r.stderr.strip()[-2000:]}")
    report = json.loads(r.stdout)
    return report["held_out"]["mean_psnr"], report["frames"], time.time() - start


def compare(cli, tmp, name, direct, bag_spec, frames, preset, tolerance):
    a, fa, ta = run_map(cli, direct, os.path.join(tmp, name + "_direct"), frames, preset)
    b, fb, tb = run_map(cli, bag_spec, os.path.join(tmp, name + "_bag"), frames, preset)
    print(f"{name}: {direct.split('?')[0]} {a:.4f} dB ({ta:.1f} s), rosbag {b:.4f} dB ({tb:.1f} s), "
          f"difference {b - a:+.4f} dB, frames {fa} / {fb}")
    if fa != fb:
        sys.exit(f"FAIL: {name}: the bag gave {fb} frames, the dataset {fa}")
    if abs(a - b) > tolerance:
        sys.exit(f"FAIL: {name}: held-out PSNR differs by {b - a:+.4f} dB (tolerance {tolerance})")


def expect_error(cli, spec, must_name, label):
    r = subprocess.run([cli, "inspect", spec], capture_output=True, text=True, timeout=120)
    lines = [l for l in r.stderr.splitlines() if "error" in l.lower()]
    ok = 0 < r.returncode < 128 and len(lines) == 1 and all(s in lines[0] for s in must_name)
    print(f"{'ok  ' if ok else 'FAIL'} {label}: exit {r.returncode}: {lines[0] if lines else r.stderr.strip()}")
    return ok


def damaged_bags(cli, bag, tmp):
    import rosbag
    import rospy
    from sensor_msgs.msg import CameraInfo, Image

    stereo = "?left=/stereo/left/image_rect&right=/stereo/right/image_rect"
    ok = True
    ok &= expect_error(cli, f"rosbag:{bag}?left=/cam/missing", [bag, "/cam/missing"], "missing topic")
    ok &= expect_error(cli, f"rosbag:{bag}?left=/stereo/left/camera_info", [bag, "/stereo/left/camera_info", "sensor_msgs/Image"],
                       "wrong message type")
    ok &= expect_error(cli, f"rosbag:{bag}?left=/stereo/left/image_rect&right=/stereo/right/image_rect&world=odom",
                       [bag, "odom"], "missing tf frame")
    ok &= expect_error(cli, f"rosbag:{bag}?left=/stereo/left/image_rect&rigth=/x", ["rigth"], "unknown key")
    ok &= expect_error(cli, f"rosbag:{bag}?left=/stereo/left/image_rect&sync=abc", ["sync", "abc"], "bad sync")
    ok &= expect_error(cli, f"rosbag:{os.path.join(tmp, 'absent.bag')}{stereo}", ["absent.bag"], "no such file")

    truncated = os.path.join(tmp, "truncated.bag")
    with open(bag, "rb") as src, open(truncated, "wb") as dst:
        dst.write(src.read(os.path.getsize(bag) // 2))
    ok &= expect_error(cli, f"rosbag:{truncated}{stereo}", [truncated, "truncated"], "truncated bag")

    garbage = os.path.join(tmp, "garbage.bag")
    with open(garbage, "wb") as f:
        f.write(b"#ROSBAG V2.0\n" + os.urandom(4096))
    ok &= expect_error(cli, f"rosbag:{garbage}{stereo}", [garbage], "garbage after the version line")

    def small_bag(path, encoding, data_bytes, info=True, d=()):
        with rosbag.Bag(path, "w") as b:
            for i in range(3):
                stamp = rospy.Time(100 + i)
                img = Image(encoding=encoding, width=8, height=4, step=8 * (2 if encoding == "yuv422" else 1))
                img.header.stamp, img.header.frame_id = stamp, "cam"
                img.data = bytes(data_bytes)
                b.write("/cam/image", img, stamp)
                if info:
                    ci = CameraInfo(width=8, height=4, K=[5, 0, 4, 0, 5, 2, 0, 0, 1], R=[1, 0, 0, 0, 1, 0, 0, 0, 1],
                                    P=[5, 0, 4, 0, 0, 5, 2, 0, 0, 0, 1, 0], D=list(d),
                                    distortion_model="plumb_bob" if d else "")
                    ci.header.stamp = stamp
                    b.write("/cam/camera_info", ci, stamp)

    yuv = os.path.join(tmp, "yuv.bag")
    small_bag(yuv, "yuv422", [0] * 64)
    ok &= expect_error(cli, f"rosbag:{yuv}?left=/cam/image", [yuv, "/cam/image", "yuv422"], "unsupported encoding")
    short = os.path.join(tmp, "short.bag")
    small_bag(short, "mono8", [0] * 10)
    ok &= expect_error(cli, f"rosbag:{short}?left=/cam/image", [short, "/cam/image", "bytes"], "image data too short")
    no_info = os.path.join(tmp, "noinfo.bag")
    small_bag(no_info, "mono8", [0] * 32, info=False)
    ok &= expect_error(cli, f"rosbag:{no_info}?left=/cam/image", [no_info, "/cam/camera_info"], "no camera_info")
    # nan distortion blanked every pixel: a map of no Gaussians whose only message blamed the depth.
    nan_d = os.path.join(tmp, "nan_distortion.bag")
    small_bag(nan_d, "mono8", [0] * 32, d=[float("nan")] * 5)
    ok &= expect_error(cli, f"rosbag:{nan_d}?left=/cam/image", [nan_d, "/cam/camera_info", "distortion"],
                       "nan distortion")
    # Finite but absurd coefficients did the same: every pixel looked up outside the raw image.
    huge_d = os.path.join(tmp, "huge_distortion.bag")
    small_bag(huge_d, "mono8", [0] * 32, d=[1e30] * 5)
    ok &= expect_error(cli, f"rosbag:{huge_d}?left=/cam/image", [huge_d, "/cam/camera_info", "distortion"],
                       "absurd distortion")
    if not ok:
        sys.exit("FAIL: a damaged bag was not refused with one clear error")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cli", required=True)
    ap.add_argument("--to-bag", required=True, help="chungs_dataset_to_bag")
    ap.add_argument("--data", required=True, help="the shared data folder")
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--tolerance", type=float, default=0.3)
    ap.add_argument("--keep", action="store_true")
    a = ap.parse_args()
    kitti = os.path.join(a.data, "kitti_seq1")
    if not os.path.isdir(kitti):
        print(f"SKIP: {kitti} is missing")
        return 77
    tmp = tempfile.mkdtemp(prefix="rosbag_test_")
    try:
        bag = os.path.join(tmp, "kitti.bag")
        subprocess.run([a.to_bag, "kitti:" + kitti, bag, "--max-frames", str(a.frames)], check=True)
        compare(a.cli, tmp, "kitti stereo", "kitti:" + kitti,
                f"rosbag:{bag}?left=/stereo/left/image_rect&right=/stereo/right/image_rect", a.frames, "outdoor",
                a.tolerance)

        room = os.path.join(tmp, "room")
        subprocess.run([a.cli, "synth", "room", "--out", room, "--frames", "30", "--width", "320", "--height", "240"],
                       check=True, capture_output=True)
        room_bag = os.path.join(tmp, "room.bag")
        subprocess.run([a.to_bag, "tum:" + room, room_bag], check=True)
        compare(a.cli, tmp, "room RGB-D", "tum:" + room,
                f"rosbag:{room_bag}?color=/camera/color/image_raw&depth=/camera/depth/image_raw", 30, "indoor",
                a.tolerance)

        damaged_bags(a.cli, bag, tmp)
        print("PASS")
        return 0
    finally:
        if a.keep:
            print(f"kept {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
