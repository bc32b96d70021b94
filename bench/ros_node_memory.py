#!/usr/bin/python3
"""The ROS node's host memory over a street many times its budget, fed at the recording's rate (anytime pacing,
poses from tf, CPU), beside `diskchungs run` on the same frames with the same budget (bench/README.md, "The ROS
node's host memory"). Needs the ROS packages (scripts/setup.sh --ros) and a build with the node.

  /usr/bin/python3 bench/ros_node_memory.py [--street-m 2000] [--budget 12000] [--build build] [--work /tmp/rss]

Writes WORK/node_rss.csv (seconds, MB, sampled twice a second while the bag plays) and prints the RSS of both over
the last part of the drive, once each holds its 400 keyframe images (keyframes.max_in_memory)."""
import argparse
import json
import os
import signal
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "ros"))
import node_test as nt  # noqa: E402  (its roscore, launch and process helpers)

TOPICS = ["/stereo/left/image_rect", "/stereo/left/camera_info", "/stereo/right/image_rect",
          "/stereo/right/camera_info", "/tf", "/tf_static"]


def rss_mb(pid):
    with open(f"/proc/{pid}/status") as f:
        return next(int(l.split()[1]) for l in f if l.startswith("VmRSS")) / 1024


def spread(values):
    lo, hi = min(values), max(values)
    return f"{lo:.1f}-{hi:.1f} MB ({100 * (hi - lo) / lo:.1f} % apart, {len(values)} samples)"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--street-m", type=int, default=2000)
    ap.add_argument("--budget", type=int, default=12000)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--work", default="/tmp/ros_node_memory")
    ap.add_argument("--tail-s", type=float, default=60, help="seconds at the end of the drive the figures cover")
    a = ap.parse_args()
    cli = os.path.join(a.build, "apps", "diskchungs", "diskchungs")
    os.makedirs(a.work, exist_ok=True)
    street = os.path.join(a.work, "street")
    bag = os.path.join(a.work, "street.bag")
    if not os.path.exists(bag):
        subprocess.run([cli, "synth", "street", "--out", street, "--length-m", str(a.street_m), "--width", "310",
                        "--height", "94", "--seed", "15", "--no-depth"], check=True, capture_output=True)
        subprocess.run([os.path.join(a.build, "ros", "chungs_dataset_to_bag"), "kitti:" + street, bag], check=True,
                       capture_output=True)
    settings = os.path.join(a.work, "settings.yaml")
    with open(settings, "w") as f:
        json.dump({"mapper": {"pacing": "anytime"}, "residency": {"budget_gaussians": a.budget}, "device": "cpu"}, f)
    ros = nt.Ros(a.work, os.path.join(a.build, "ros"))
    try:
        out = os.path.join(a.work, "node_map")
        subprocess.run(["rm", "-rf", out], check=True)
        node, log = nt.launch(ros, os.path.join(ROOT, "ros", "launch", "kitti_stereo.launch"), out, settings)
        nt.wait_service("/diskchungs/stop", node, log)
        pids = nt.node_pids(node)
        if not pids:
            nt.fail("no diskchungs_node under roslaunch")
        pid = pids[0]
        play = subprocess.Popen(["rosbag", "play", "--quiet", "--wait-for-subscribers", "--delay", "0.5", bag,
                                 "--topics"] + TOPICS, env=ros.env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.STDOUT)
        t0, rows = time.time(), []
        while play.poll() is None:
            rows.append((time.time() - t0, rss_mb(pid)))
            time.sleep(0.5)
        os.killpg(node.pid, signal.SIGINT)
        node.wait(timeout=600)
        with open(os.path.join(a.work, "node_rss.csv"), "w") as f:
            f.writelines(f"{s:.1f},{r:.1f}\n" for s, r in rows)
        end = rows[-1][0]
        print(f"node: {len(rows)} samples over {end:.0f} s; RSS over the last {a.tail_s:.0f} s: "
              f"{spread([r for s, r in rows if s >= end - a.tail_s])}")
    finally:
        for p in nt.LAUNCHED:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGINT)
        ros.close()
    run_map = os.path.join(a.work, "run_map")
    subprocess.run(["rm", "-rf", run_map], check=True)
    subprocess.run([cli, "run", "--dataset", "kitti:" + street, "--poses", "gt", "--device", "cpu", "--pacing",
                    "anytime", "--budget", str(a.budget), "--no-eval", "--quiet", "--out", run_map], check=True,
                   env=dict(os.environ, OMP_NUM_THREADS="1"), capture_output=True)
    with open(os.path.join(run_map, "timeline.csv")) as f:
        head = f.readline().strip().split(",")
        rows = [dict(zip(head, map(float, l.split(",")))) for l in f]
    end = rows[-1]["seconds"]
    print(f"run: RSS over the last {a.tail_s:.0f} s of its intake: "
          f"{spread([r['rss_mb'] for r in rows if r['seconds'] >= end - a.tail_s])}")


if __name__ == "__main__":
    main()
