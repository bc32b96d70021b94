"""The hostile-input cases. Each names its command (run in the case's own folder, so paths are
relative), what it expects (an error whose message contains every word in `says`, or success), and
how it damages its copy of a seed. Inputs are made here, never committed."""

import shlex

import forge
from forge import png, jpeg_header

# Map a dataset fast: one step per keyframe, no refinement, no held-out scoring.
FAST = {"--device": "cpu", "--iterations": "1", "--final-iterations": "0"}
RUN = "run --no-eval " + " ".join("%s %s" % kv for kv in FAST.items())


def run_without(flag):
    """RUN less the flag under test: given twice, CLI11 would refuse the pair before the value."""
    return "run --no-eval " + " ".join("%s %s" % kv for kv in FAST.items() if kv[0] != flag)
STREET = "synth-street:length=12,width=64,height=48,seed=2"

# Classes another change of issue 21 took on; a failing case of one says so in its line.
PNG_BOMB = "image decoding allocates before a size limit"
STORE_HEADER = "chunk/keyframe header sizes trusted before allocation"
BAD_ALLOC = "std::bad_alloc reaches the CLI boundary"
KITTI_FX = "KITTI P1 focal length not compared with P0"
TUM_ORDER = "TUM timestamps out of order accepted"
TUM_DEPTH8 = "8-bit PNG read as TUM depth"
RENDER_OUT = "render writes its PNGs inside the map folder by default"


class Case:
    def __init__(self, name, cmd, expect, says=(), setup=None, watch=(), timeout=60, quick=False, known=None,
                 hold_lock=None):
        self.name, self.cmd, self.expect, self.says = name, cmd, expect, tuple(says)
        self.setup, self.watch, self.timeout, self.quick, self.known = setup, tuple(watch), timeout, quick, known
        self.hold_lock = hold_lock

    def argv(self):
        return shlex.split(self.cmd)


def err(name, cmd, says, setup=None, **kw):
    """A case whose input is invalid: the command must fail and its message contain every word of
    `says` (a string is one word; a tuple, words any one of which will do)."""
    return Case(name, cmd, "error", [says] if isinstance(says, (str, tuple)) else says, setup, **kw)


def naming(flag, value=""):
    """The words that name a flag at fault: the flag itself, or the setting it sets (`--max-dt` sets
    max_dt), or a typed value that is not a number (a word or a file name)."""
    words = tuple(dict.fromkeys((flag, flag[2:], flag[2:].replace("-", "_"))))
    try:
        float(value)
        return words
    except ValueError:
        return words + ((value,) if len(value) >= 3 else ())


def ok(name, cmd, setup=None, **kw):
    return Case(name, cmd, "ok", (), setup, **kw)


# ---------------------------------------------------------------------------------------------
# Setup builders: a seed copied into the case folder, then damaged.


def seed(name, dest=None):
    return lambda d, s: s.copy(name, d / (dest or name))


def dataset(kind, *damage):
    """The seed dataset `kind` as ds/, damaged in order."""
    def setup(d, s):
        s.copy(kind, d / "ds")
        for f in damage:
            f(d / "ds")
    return setup


def a_map(*damage, name="map"):
    def setup(d, s):
        s.copy(name, d / "map")
        for f in damage:
            f(d / "map")
    return setup


def both(*setups):
    def setup(d, s):
        for f in setups:
            f(d, s)
    return setup


def put(rel, data):
    return lambda root: forge.write(root / rel, data() if callable(data) else data)


def rm(rel):
    return lambda root: forge.remove(root / rel)


def trunc(rel, keep):
    return lambda root: forge.truncate(root / rel, keep)


def flip(rel, offset):
    return lambda root: forge.flip_byte(root / rel, offset)


def sub(rel, old, new, count=1):
    return lambda root: forge.replace_in(root / rel, old, new, count)


def field(rel, line, index, value):
    return lambda root: forge.edit_field(root / rel, line, index, value)


def lines(rel, fn):
    return lambda root: forge.edit_lines(root / rel, fn)


def fifo(rel):
    return lambda root: forge.make_fifo(root / rel)


def folder(rel):
    return lambda root: forge.make_dir(root / rel)


def devzero(rel):
    return lambda root: forge.link_to(root / rel, "/dev/zero")


def file_in(rel, data):
    """A file in the case folder itself (next to ds/ and map/)."""
    return lambda d, s: forge.write(d / rel, data() if callable(data) else data)


# The first chunk file of a map, whatever its id.
def first_chunk(root):
    return sorted((root / "chunks").iterdir())[0]


def chunk(fn):
    return lambda root: fn(first_chunk(root))



def manifest(fn):
    """Rewrites the manifest body with fn and signs it again, so the parser reaches the field."""
    def damage(root):
        body = forge.manifest_body(root / "manifest.txt")
        forge.write(root / "manifest.txt", forge.manifest_text(fn(body)))
    return damage


def manifest_chunk_field(index, value):
    def fn(body):
        out = []
        for line in body.splitlines():
            if line.startswith("chunk "):
                tokens = line.split()
                tokens[index] = value
                line = " ".join(tokens)
            out.append(line)
        return "\n".join(out) + "\n"
    return fn


# ---------------------------------------------------------------------------------------------
# The command line.


def cli_cases():
    c = [
        err("cli.no_arguments", "", "subcommand", quick=True),
        err("cli.unknown_command", "frobnicate", "frobnicate", quick=True),
        err("cli.unknown_command_after_global_flag", "-q frobnicate", "frobnicate"),
        err("cli.synth_unknown_scene", "synth castle --out x", "castle"),
        err("cli.eval_unknown_kind", "eval speed --gt a --est b", "speed"),
        err("cli.synth_no_scene", "synth", "subcommand"),
        err("cli.eval_no_kind", "eval", "subcommand"),
        err("cli.info_extra_argument", "info extra", "extra"),
        err("cli.inspect_two_datasets", "inspect tum:a tum:b", "tum:b"),
        err("cli.run_missing_value", "run --dataset", "--dataset"),
        err("cli.empty_dataset", RUN + " --dataset '' --out out", "dataset"),
        err("cli.dataset_unknown_kind", "inspect castle:ds", "castle", quick=True),
        err("cli.dataset_without_kind", "inspect ds", "KIND:PATH"),
        err("cli.dataset_missing_folder", "inspect tum:nowhere", "nowhere", quick=True),
        err("cli.dataset_is_a_file", "inspect tum:f.txt", "f.txt", file_in("f.txt", "x\n")),
        ok("cli.quiet_after_command", "info -q", quick=True),
        ok("cli.verbose_after_command", "inspect tum:ds -v", dataset("tum")),
        ok("cli.quiet_after_synth_scene", "synth room --out out --frames 2 --width 32 --height 32 -q"),
        # Both asked for two levels of messages; the later one won without a word.
        err("cli.quiet_and_verbose", "-q info -v", ("--quiet", "--verbose")),
        ok("cli.help", "--help"),
        ok("cli.run_help", "run --help"),
    ]
    unknown_flag = {
        "run": RUN + " --dataset tum:ds --out out",
        "track": "track --dataset tum:ds --out t.txt",
        "synth_room": "synth room --out out --frames 2",
        "render": "render --map map --poses traj.txt --out r",
        "export": "export --map map --out x.ply",
        "demo": "demo --out out",
        "eval_ate": "eval ate --gt traj.txt --est traj.txt",
        "eval_images": "eval images --ref ref --test test",
        "inspect": "inspect tum:ds",
        "info": "info",
    }
    setups = {"run": dataset("tum"), "track": dataset("tum"), "inspect": dataset("tum"),
              "render": both(a_map(), seed("traj_tum.txt", "traj.txt")), "export": a_map(),
              "eval_ate": seed("traj_tum.txt", "traj.txt"),
              "eval_images": both(seed("images_ref", "ref"), seed("images_test", "test"))}
    for name, cmd in unknown_flag.items():
        c.append(err("cli.unknown_flag." + name, cmd + " --frobnicate 3", "--frobnicate", setups.get(name),
                     watch=["map"] if name in ("render", "export") else (), quick=name == "run"))
    return c


def number_cases():
    """Every numeric (and enumerated) flag, with values a typo or a script could pass."""
    c = []

    def flags(prefix, base, table, setup=None, quick_first=False):
        for flag, values in table:
            for i, v in enumerate(values):
                name = "%s%s=%s" % (prefix, flag, v if v else "empty")
                command = base(flag) if callable(base) else base
                c.append(err(name, "%s %s %s" % (command, flag, shlex.quote(v)), naming(flag, v), setup,
                             quick=quick_first and i == 0))

    flags("num.run", lambda flag: run_without(flag) + " --dataset %s --out out" % STREET, [
        ("--budget", ["-1", "0", "nan", "abc", "99999999999999999999", "3500000000"]),
        ("--chunk-size", ["-1", "0", "nan", "inf", "abc"]),
        ("--resolution", ["-0.5", "0", "1.5", "nan", "inf", "abc"]),
        ("--iterations", ["-1", "abc", "99999999999"]),
        ("--final-iterations", ["-1", "abc"]),
        ("--speed", ["0", "-1", "nan", "inf", "abc", "1e308"]),
        ("--fill-depth", ["-1", "nan", "inf", "1e300"]),
        ("--max-frames", ["0", "-1", "abc"]),
        ("--pacing", ["sometimes", ""]),
        ("--depth", ["lidar"]),
        ("--device", ["tpu"]),
        ("--preset", ["underwater"]),
    ], quick_first=True)
    # A chunk edge so small that the room's chunk coordinates leave the id's range.
    c.append(err("num.run--chunk-size=1e-9", RUN + " --dataset tum:ds --out out --chunk-size 1e-9", "chunk",
                 dataset("tum")))

    track = "track --dataset tum:ds --out t.txt"
    flags("num.track", track, [
        ("--max-frames", ["-1", "abc"]),
        ("--kf-min-interval", ["-5", "abc"]),
        ("--kf-max-interval", ["-5"]),
        ("--rgbd-baseline", ["-1", "nan", "inf"]),
        ("--format", ["csv"]),
    ], dataset("tum"), quick_first=True)
    c.append(err("num.track_kf_min_beyond_max", track + " --kf-min-interval 10 --kf-max-interval 2",
                 "--kf-min-interval", dataset("tum")))

    room = "synth room --out out --frames 2 --width 32 --height 32"
    flags("num.synth_room", "synth room --out out --width 32 --height 32", [
        ("--frames", ["-3", "0", "abc", "nan"]),
    ], quick_first=True)
    flags("num.synth_room", "synth room --out out --frames 2 --height 32", [("--width", ["-5", "0", "abc"])])
    flags("num.synth_room", "synth room --out out --frames 2 --width 32", [("--height", ["-1", "0"])])
    flags("num.synth_room", room, [
        ("--seed", ["-1", "abc"]),
        ("--layout", ["euroc"]),
    ])
    flags("num.synth_room", room + " --layout kitti", [("--baseline", ["-0.1", "0", "nan", "inf"])])
    # 100000 x 100000 pixels from a 30-byte command line.
    c.append(err("num.synth_room--width=100000", "synth room --out out --frames 1 --width 100000 --height 100000",
                 "--width", quick=True))
    street = "synth street --out out --frames 2 --width 32 --height 32"
    flags("num.synth_street", street, [
        ("--length-m", ["-1", "0", "nan", "inf", "1e308", "abc"]),
    ])
    flags("num.synth_street", "synth street --out out --length-m 20 --width 32 --height 32",
          [("--frames", ["-1"])])
    flags("num.synth_street", "synth street --out out --frames 2 --height 32", [("--width", ["0"])])

    def mesh_setup(d, s):
        forge.write(d / "mesh.ply", MESH_PLY)
        forge.write(d / "traj.txt", "0 0 0 -2 0 0 0 1\n")
    mesh = "synth mesh --mesh mesh.ply --traj traj.txt --out out"
    intr = "--intrinsics 50,50,32,24,64,48"
    flags("num.synth_mesh", mesh + " " + intr, [
        ("--every", ["0", "-1"]),
        ("--rate", ["0", "-30", "nan"]),
        ("--frames", ["-1"]),
        ("--baseline", ["-1"]),
    ], mesh_setup)
    flags("num.synth_mesh", mesh, [
        ("--intrinsics", ["50,50,32,24", "a,b,c,d,e,f", "50,50,32,24,0,48", "50,50,32,24,64.5,48",
                          "nan,50,32,24,64,48", "50,50,32,24,1e12,48", "50,50,32,24,100000,100000", "",
                          "missing.json", "50,50,32,24,64,48,"]),
    ], mesh_setup)

    render = "render --map map --poses traj.txt --out r"
    render_setup = both(a_map(), seed("traj_tum.txt", "traj.txt"))
    for flag, values in [("--resolution", ["-1", "2", "nan", "0"]), ("--stride", ["0", "-1", "abc"]),
                         ("--budget", ["-1", "0", "abc"]), ("--dataset-poses", ["sideways"])]:
        for v in values:
            extra = " --dataset tum:ds" if flag == "--dataset-poses" else ""
            base = render.replace("--poses traj.txt", "") + extra if extra else render
            c.append(err("num.render%s=%s" % (flag, v), "%s %s %s" % (base, flag, v), naming(flag, v),
                         both(render_setup, dataset("tum")) if extra else render_setup, watch=["map"]))
    c.append(err("num.render_poses_and_dataset", render + " --dataset tum:ds", "--poses",
                 both(render_setup, dataset("tum")), watch=["map"]))
    c.append(err("num.render_neither_poses_nor_dataset", "render --map map --out r", "--poses", a_map(),
                 watch=["map"]))
    # A FIFO where a render goes waited for a reader for ever; a link there into the map replaced its manifest.
    def in_r(make):
        def setup(d, s):
            (d / "r").mkdir(exist_ok=True)
            make(d)
        return setup
    c.append(err("out.render_png_is_fifo", render, "render_000000.png",
                 both(render_setup, in_r(lambda d: forge.make_fifo(d / "r" / "render_000000.png"))), watch=["map"],
                 timeout=30))
    c.append(err("out.render_png_links_into_map", render, "render_000000.png",
                 both(render_setup, in_r(lambda d: forge.link_to(d / "r" / "render_000000.png",
                                                                 str(d / "map" / "manifest.txt")))), watch=["map"]))
    # export renamed its file over a FIFO (as root, over /dev/full too: /dev then held a regular file).
    c.append(err("out.export_over_fifo", "export --map map --out x.ply", "x.ply",
                 both(a_map(), lambda d, s: forge.make_fifo(d / "x.ply")), watch=["map", "x.ply"]))
    c.append(err("map.export_manifest_link_loop", "export --map map --out x.ply", "manifest.txt",
                 a_map(lambda root: forge.link_to(root / "manifest.txt", "manifest.txt")), watch=["map"]))
    # 100,000 '[' in a map's JSON ran the stack out (SIGSEGV) in render.
    deep = '{"settings": ' + "[" * 100000 + "]" * 100000 + "}\n"
    c.append(err("map.render_report_json_deep", render, "report.json",
                 both(a_map(put("report.json", deep)), seed("traj_tum.txt", "traj.txt")), watch=["map"]))

    export = "export --map map --out x.ply"
    for name, extra, word in [("chunk_two_values", "--chunk 1 2", "--chunk"),
                              ("chunk_words", "--chunk a b c", "--chunk"),
                              ("chunk_out_of_range", "--chunk 99999999 0 0", "99999999"),
                              ("box_nan", "--box nan 0 0 1 1 1", "--box"),
                              ("box_inverted", "--box 1 1 1 0 0 0", "--box"),
                              ("box_inf", "--box -inf 0 0 inf 1 1", "--box"),
                              ("box_five_values", "--box 0 0 0 1 1", "--box"),
                              ("box_empty_value", "--box '' -5 -5 10 5 5", "--box")]:
        c.append(err("num.export_" + name, export + " " + extra, word, a_map(), watch=["map"]))
    c.append(err("num.export--out=empty", "export --map map --out ''", "--out", a_map(), watch=["map"]))
    # Below 0.01 s the follower polled the folder without a pause; a file given with --wait waited forever.
    c.append(err("num.view--follow=1e-300", "view map --port 0 --follow 1e-300", "--follow", a_map(), watch=["map"]))
    c.append(err("num.view_wait_on_a_file", "view notes.txt --port 0 --wait", "notes.txt", file_in("notes.txt", "x\n"),
                 timeout=20))

    demo = "demo --out out"
    flags("num.demo", demo, [
        ("--length-m", ["nan", "-1", "10", "1e9"]),
        ("--frames", ["-1"]),
        ("--resolution", ["2", "nan"]),
        ("--iterations", ["-1"]),
        ("--final-iterations", ["-5"]),
        ("--budget", ["-1", "abc"]),
        ("--chunk-size", ["nan", "-2"]),
        ("--scene", ["forest"]),
    ])
    flags("num.demo", demo, [("--seed", ["-1"])])
    flags("num.demo_room", demo + " --scene room", [("--frames", ["0", "3"])])
    # --out naming a file gave the filesystem's own words, naming no flag.
    c.append(err("num.demo--out=file", "demo --out notes.txt", "--out", file_in("notes.txt", "x\n"), watch=["notes.txt"]))

    ate = "eval ate --gt traj.txt --est traj.txt"
    flags("num.eval_ate", ate, [
        ("--max-dt", ["-1", "nan", "abc"]),
        ("--rpe-delta", ["0", "-1", "abc"]),
        ("--align", ["affine"]),
    ], seed("traj_tum.txt", "traj.txt"), quick_first=True)
    # CLI11 read an empty text as 0 for a decimal flag and took hexadecimal.
    c.append(err("num.eval_ate--max-dt=empty", ate + " --max-dt ''", "--max-dt", seed("traj_tum.txt", "traj.txt")))
    c.append(err("num.synth_street--length-m=hex", street + " --length-m 0x10", "--length-m"))
    # 2^31 frames: the room's trajectory was built whole first (2.6 GB at the case's memory cap).
    c.append(err("num.synth_room--frames=2^31", "synth room --out out --frames 2147483648 --width 32 --height 24",
                 "--frames"))
    # 16384 a side passed the side check, then took gigabytes; the readers take 8192 x 8192 at most.
    c.append(err("num.synth_room_area", "synth room --out out --frames 1 --width 16384 --height 16384", "--width"))
    c.append(err("num.synth_room--out=empty", "synth room --out '' --frames 1 --width 32 --height 24", "--out"))
    # Written into a real dataset, a sequence replaced its calib.txt and poses.txt and left its images beside.
    c.append(err("num.synth_street_into_a_dataset", "synth street --out ds --length-m 5 --width 32 --height 24", "ds",
                 dataset("kitti", rm("camera.txt")), watch=["ds"]))  # the seed is synthetic: its camera.txt says so
    # Frames are named by their stamps to the microsecond: at 1e300 Hz five frames shared one file.
    c.append(err("num.synth_mesh--rate=1e300", mesh + " " + intr + " --rate 1e300", "--rate", mesh_setup))
    return c


MESH_PLY = ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n"
            "property list uchar int vertex_indices\nend_header\n"
            "-1 -1 0 255 0 0\n1 -1 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n")


def synth_cases():
    """Files `synth mesh` reads: the mesh and the trajectory."""
    c = []
    intr = "--intrinsics 50,50,32,24,64,48"
    cmd = "synth mesh --mesh mesh.ply --traj traj.txt --out out " + intr

    def setup(mesh=MESH_PLY, traj="0 0 0 -2 0 0 0 1\n"):
        def s(d, _):
            forge.write(d / "mesh.ply", mesh)
            forge.write(d / "traj.txt", traj)
        return s

    ok_cmd = ok("synth.mesh_valid", cmd, setup(), quick=True)
    c.append(ok_cmd)
    for name, mesh in [
        ("empty", ""),
        ("not_ply", "hello\n"),
        ("no_end_header", "ply\nformat ascii 1.0\nelement vertex 3\n"),
        ("binary_big_endian", MESH_PLY.replace("ascii", "binary_big_endian")),
        ("count_beyond_file", MESH_PLY.replace("element vertex 3", "element vertex 99999999999")),
        ("negative_count", MESH_PLY.replace("element vertex 3", "element vertex -3")),
        ("truncated_body", MESH_PLY[: MESH_PLY.index("1 -1 0")]),
        ("face_index_out_of_range", MESH_PLY.replace("3 0 1 2", "3 0 1 7")),
        ("face_list_huge", MESH_PLY.replace("3 0 1 2", "200 0 1 2")),
        ("vertex_nan", MESH_PLY.replace("-1 -1 0 255", "nan -1 0 255")),
        ("vertex_inf", MESH_PLY.replace("-1 -1 0 255", "inf -1 0 255")),
        ("vertex_word", MESH_PLY.replace("-1 -1 0 255", "minus -1 0 255")),
        ("colour_beyond_uchar", MESH_PLY.replace("-1 -1 0 255", "-1 -1 0 300")),
        ("no_vertex_element", "ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\n"
                              "end_header\n"),
        # A header's count short of its body, and a face line of more values than its length, dropped data unsaid.
        ("faces_beyond_the_count", MESH_PLY + "3 0 1 2\n3 2 1 0\n"),
        ("face_line_longer_than_its_length", MESH_PLY.replace("3 0 1 2", "3 0 1 2 7")),
    ]:
        c.append(err("synth.mesh_" + name, cmd, "mesh.ply", setup(mesh=mesh)))
    # A mesh with no faces gave a blank sequence, exit 0, without a word.
    c.append(Case("synth.mesh_no_faces", cmd, "error_or_warning", ["triangle"],
                  setup(mesh=MESH_PLY.replace("element face 1", "element face 0").replace("3 0 1 2\n", ""))))
    c.append(err("synth.mesh_is_fifo", cmd, "mesh.ply", both(setup(), lambda d, s: forge.make_fifo(d / "mesh.ply")),
                 timeout=30))
    c.append(err("synth.mesh_is_folder", cmd, "mesh.ply", both(setup(), lambda d, s: forge.make_dir(d / "mesh.ply"))))
    for name, traj in [("empty", ""), ("nan", "0 nan 0 -2 0 0 0 1\n"), ("zero_quaternion", "0 0 0 -2 0 0 0 0\n"),
                       ("words", "zero one two\n"), ("seven_fields", "0 0 0 -2 0 0 1\n"),
                       ("matrix_last_row_not_0001", "1 0 0 0 0 1 0 0 0 0 1 0 5 6 7 8\n")]:
        c.append(err("synth.traj_" + name, cmd, "traj.txt", setup(traj=traj)))
    # The sequence writes its folder's trajectory: --traj out/poses.txt --out out was rewritten as the new one.
    c.append(err("synth.traj_in_the_output_folder", "synth mesh --mesh mesh.ply --traj out/poses.txt --out out " + intr,
                 ("--traj", "poses.txt"), both(setup(), file_in("out/poses.txt", "0 0 0 -2 0 0 0 1\n")),
                 watch=["out/poses.txt"]))
    c.append(err("synth.check_office0_missing", "synth check-office0 --data nowhere", "nowhere"))
    c.append(err("synth.out_is_a_file", "synth room --out f.txt --frames 2 --width 32 --height 32", "f.txt",
                 file_in("f.txt", "x\n")))
    return c


# ---------------------------------------------------------------------------------------------
# Configuration files.


def config_cases():
    c = []
    info = "info --config-file cfg.yaml"
    for name, text, words in [
        ("malformed", "store: [chunk_size: 1\n", "cfg.yaml"),
        ("top_level_list", "- store\n- residency\n", "cfg.yaml"),
        ("top_level_scalar", "hello\n", "cfg.yaml"),
        ("unknown_section", "stor:\n  chunk_size: 2\n", "stor"),
        ("unknown_key", "store:\n  chunk_sizee: 2\n", "chunk_sizee"),
        ("section_not_a_map", "store: 5\n", "store"),
        ("wrong_type_number", "store:\n  chunk_size: big\n", "chunk_size"),
        ("wrong_type_bool", "store:\n  compress: maybe\n", "compress"),
        ("wrong_type_list", "raster:\n  background: [0, 0]\n", "background"),
        ("list_for_number", "store:\n  chunk_size: [1, 2]\n", "chunk_size"),
        ("duplicate_key", "store:\n  chunk_size: 2\n  chunk_size: 3\n", "chunk_size"),
        ("duplicate_section", "store:\n  chunk_size: 2\nstore:\n  sh_degree: 1\n", "store"),
        ("chunk_size_negative", "store:\n  chunk_size: -1\n", "chunk_size"),
        ("chunk_size_nan", "store:\n  chunk_size: .nan\n", "chunk_size"),
        ("chunk_size_inf", "store:\n  chunk_size: .inf\n", "chunk_size"),
        ("sh_degree_9", "store:\n  sh_degree: 9\n", "sh_degree"),
        ("zstd_level_9999", "store:\n  zstd_level: 9999\n", "zstd_level"),
        ("budget_negative", "residency:\n  budget_gaussians: -5\n", "budget_gaussians"),
        ("budget_zero", "residency:\n  budget_gaussians: 0\n", "budget_gaussians"),
        ("budget_huge", "residency:\n  budget_gaussians: 99999999999999999999999\n", "budget_gaussians"),
        ("hysteresis_nan", "residency:\n  eviction_hysteresis: .nan\n", "eviction_hysteresis"),
        ("keyframes_in_memory_negative", "keyframes:\n  max_in_memory: -1\n", "max_in_memory"),
        ("keyframes_zstd_level", "keyframes:\n  zstd_level: 9999\n", "zstd_level"),
        # Refused only after the run made its map folder, naming neither file nor key.
        ("keyframes_in_memory_zero", "keyframes:\n  max_in_memory: 0\n", "max_in_memory"),
        # Infinite values passed `> 0` checks and changed the run without a word.
        ("sampler_density_inf", "sampler:\n  density: .inf\n", "density"),
        ("sampler_min_scale_inf", "sampler:\n  min_scale_px: .inf\n", "min_scale_px"),
        ("sampler_max_scale_inf", "sampler:\n  max_scale_fraction: .inf\n", "max_scale_fraction"),
        ("adam_eps_inf", "adam:\n  eps: .inf\n", "eps"),
        ("keyframe_rules_inf", "mapper:\n  keyframe_every: 0\n  keyframe_translation: .inf\n  keyframe_parallax: .inf\n"
         "  keyframe_rotation_deg: .inf\n", "keyframe_"),
        ("pose_update_translation_inf", "mapper:\n  pose_update_min_translation: .inf\n", "pose_update_min_translation"),
        ("culling_max_distance_inf", "culling:\n  max_distance: .inf\n", "max_distance"),
        ("stereo_max_depth_inf", "stereo:\n  max_depth: .inf\n", "max_depth"),
        ("stereo_min_disparity_nan", "stereo:\n  min_disparity_px: .nan\n", "min_disparity_px"),
        ("stereo_min_confidence_nan", "stereo:\n  min_confidence: .nan\n", "min_confidence"),
        ("culling_near_negative", "culling:\n  near: -1\n", "near"),
        ("culling_far_nan", "culling:\n  far: .nan\n", "far"),
        ("culling_far_below_near", "culling:\n  near: 10\n  far: 1\n", "far"),
        ("culling_cache_rotation_negative", "culling:\n  cache_rotation_rad: -1\n", "cache_rotation_rad"),
        ("raster_sh_degree_7", "raster:\n  sh_degree: 7\n", "sh_degree"),
        ("raster_alpha_max_2", "raster:\n  alpha_max: 2\n", "alpha_max"),
        ("loss_ssim_2", "loss:\n  lambda_ssim: 2\n", "lambda_ssim"),
        ("adam_lr_negative", "adam:\n  lr_position: -1\n", "lr_position"),
        ("adam_lr_nan", "adam:\n  lr_opacity: .nan\n", "lr_opacity"),
        ("adam_beta1_above_1", "adam:\n  beta1: 1.5\n", "beta1"),
        ("prune_every_negative", "prune:\n  every: -1\n", "every"),
        ("mapper_resolution_zero", "mapper:\n  resolution: 0\n", "resolution"),
        ("mapper_resolution_nan", "mapper:\n  resolution: .nan\n", "resolution"),
        ("mapper_pacing_word", "mapper:\n  pacing: sometimes\n", "pacing"),
        ("mapper_depth_word", "mapper:\n  depth: lidar\n", "depth"),
        ("mapper_iterations_negative", "mapper:\n  iterations_per_keyframe: -1\n", "iterations_per_keyframe"),
        ("mapper_holdout_negative", "mapper:\n  holdout_every: -1\n", "holdout_every"),
        ("mapper_checkpoint_seconds_nan", "mapper:\n  checkpoint_seconds: .nan\n", "checkpoint_seconds"),
        ("mapper_speed_inf", "mapper:\n  speed: .inf\n", "speed"),
        ("sampler_stride_zero", "sampler:\n  stride: 0\n", "stride"),
        ("sampler_density_negative", "sampler:\n  density: -1\n", "density"),
        ("selector_budget_share_2", "selector:\n  budget_share: 2\n", "budget_share"),
        ("selector_best_view_share_nan", "selector:\n  best_view_share: .nan\n", "best_view_share"),
        ("selector_core_share_zero", "selector:\n  core_share: 0\n", "core_share"),
        ("stereo_disparities_1000", "stereo:\n  num_disparities: 1000\n", "num_disparities"),
        ("stereo_max_depth_below_min", "stereo:\n  min_depth: 10\n  max_depth: 1\n", "max_depth"),
        ("sky_width_zero", "sky:\n  width: 0\n", "width"),
        ("sky_lr_nan", "sky:\n  lr: .nan\n", "lr"),
        ("binary_garbage", bytes(range(256)) * 4, "cfg.yaml"),
        ("deep_nesting", "a: " + "[" * 100000 + "]" * 100000 + "\n", "cfg.yaml"),
        ("alias_bomb", "".join("l%d: &l%d [%s]\n" % (i, i, ",".join(["*l%d" % (i - 1)] * 9) if i else '"lol"')
                               for i in range(10)), "l0"),
    ]:
        c.append(err("config." + name, info, words, file_in("cfg.yaml", text), quick=name == "malformed"))
    c.append(ok("config.empty", info, file_in("cfg.yaml", "")))
    c.append(ok("config.comments_only", info, file_in("cfg.yaml", "# nothing to change\n")))
    c.append(ok("config.one_key", info, file_in("cfg.yaml", "store:\n  chunk_size: 2\n")))
    c.append(err("config.missing_file", info, "cfg.yaml"))
    c.append(err("config.is_fifo", info, "cfg.yaml", lambda d, s: forge.make_fifo(d / "cfg.yaml"), timeout=30))
    c.append(err("config.is_folder", info, "cfg.yaml", lambda d, s: forge.make_dir(d / "cfg.yaml")))
    c.append(err("config.is_dev_zero", info, "cfg.yaml", lambda d, s: forge.link_to(d / "cfg.yaml", "/dev/zero"),
                 timeout=30))
    # The same file through the commands that take --config.
    bad = file_in("cfg.yaml", "residency:\n  budget_gaussians: -5\n")
    c.append(err("config.run_bad_value", RUN + " --dataset %s --out out --config cfg.yaml" % STREET,
                 "budget_gaussians", bad, quick=True))
    c.append(err("config.run_missing_file", RUN + " --dataset %s --out out --config cfg.yaml" % STREET, "cfg.yaml"))
    c.append(err("config.render_bad_value", "render --map map --poses traj.txt --out r --config cfg.yaml",
                 "budget_gaussians", both(bad, a_map(), seed("traj_tum.txt", "traj.txt")), watch=["map"]))
    # A monocular depth model (--mono-depth-model, mapper.mono_depth_model): refused before the run
    # starts, naming the file; garbage is refused by the runtime's parser, or for want of the runtime.
    mono = RUN + " --dataset %s --out out --input mono --mono-depth-model m.onnx" % STREET
    for name, setup, says in [
        ("missing", None, ["m.onnx", "does not exist"]),
        ("is_folder", lambda d, s: forge.make_dir(d / "m.onnx"), ["m.onnx", "not a file"]),
        ("is_fifo", lambda d, s: forge.make_fifo(d / "m.onnx"), ["m.onnx", "not a file"]),
        ("is_dev_zero", lambda d, s: forge.link_to(d / "m.onnx", "/dev/zero"), ["m.onnx", "not a file"]),
        ("empty", file_in("m.onnx", ""), ["m.onnx", "empty"]),
        ("garbage", file_in("m.onnx", bytes(range(256)) * 64), ["m.onnx", "ONNX Runtime"]),
        ("yaml_instead", file_in("m.onnx", "mapper:\n  budget: 1\n"), ["m.onnx", "ONNX Runtime"]),
    ]:
        c.append(err("model." + name, mono, says, setup, timeout=30))
    c.append(err("model.config_key_missing_file", RUN + " --dataset %s --out out --input mono --config cfg.yaml" % STREET,
                 ["mapper.mono_depth_model", "m.onnx"], file_in("cfg.yaml", "mapper:\n  mono_depth_model: m.onnx\n")))
    return c


# ---------------------------------------------------------------------------------------------
# Datasets. Open-time damage is seen by `inspect`; damage to a later frame only by commands that
# load every frame (`run`).

INSPECT = "inspect {kind}:ds"
RUN_DS = RUN + " --dataset {kind}:ds --out out"
TUM_RGB0, TUM_RGB2 = "rgb/0.000000.png", "rgb/0.066667.png"
TUM_STAMPS = ["%.6f" % (i / 30) for i in range(8)]
TUM_DEPTH0, TUM_DEPTH2 = "depth/0.000000.png", "depth/0.066667.png"


def ds_err(kind, name, damage, says, run=False, **kw):
    cmd = (RUN_DS if run else INSPECT).format(kind=kind)
    damage = damage if isinstance(damage, (list, tuple)) else [damage]
    return err("ds.%s.%s" % (kind, name), cmd, says, dataset(kind, *damage), watch=["ds"], **kw)


def tum_cases():
    k = "tum"
    shuffle = lambda data: [data[1], data[0]] + data[2:]  # noqa: E731 (a table of one-liners)
    c = [
        ok("ds.tum.valid_inspect", INSPECT.format(kind=k), dataset(k), watch=["ds"], quick=True),
        ok("ds.tum.valid_run", RUN_DS.format(kind=k), dataset(k), watch=["ds"]),
        ds_err(k, "rgb_txt_missing", rm("rgb.txt"), "rgb.txt", quick=True),
        ds_err(k, "rgb_txt_empty", put("rgb.txt", ""), "rgb.txt"),
        ds_err(k, "rgb_txt_comments_only", put("rgb.txt", "# nothing\n"), "rgb.txt"),
        ds_err(k, "rgb_txt_stamp_only", lines("rgb.txt", lambda d: [d[0].split()[0]] + d[1:]), "rgb.txt"),
        ds_err(k, "rgb_txt_three_columns", lines("rgb.txt", lambda d: [d[0] + " extra"] + d[1:]), "rgb.txt"),
        ds_err(k, "rgb_txt_stamp_nan", field("rgb.txt", 1, 0, "nan"), "rgb.txt"),
        ds_err(k, "rgb_txt_stamp_inf", field("rgb.txt", 1, 0, "inf"), "rgb.txt"),
        ds_err(k, "rgb_txt_stamp_negative", field("rgb.txt", 0, 0, "-1"), "rgb.txt"),
        ds_err(k, "rgb_txt_stamp_word", field("rgb.txt", 2, 0, "noon"), "rgb.txt"),
        ds_err(k, "rgb_txt_out_of_order", lines("rgb.txt", shuffle), "rgb.txt", known=TUM_ORDER),
        ds_err(k, "rgb_txt_duplicate_stamp", field("rgb.txt", 1, 0, "0.000000"), "rgb.txt", known=TUM_ORDER),
        ds_err(k, "rgb_txt_is_fifo", fifo("rgb.txt"), "rgb.txt", timeout=30),
        ds_err(k, "rgb_txt_is_folder", folder("rgb.txt"), "rgb.txt"),
        ds_err(k, "rgb_txt_is_dev_zero", devzero("rgb.txt"), "rgb.txt", timeout=30),
        ds_err(k, "rgb_txt_binary", put("rgb.txt", bytes(range(256)) * 8), "rgb.txt"),
        ds_err(k, "rgb_listed_image_missing", rm(TUM_RGB2), "0.066667.png", run=True),
        ds_err(k, "rgb_first_image_missing", rm(TUM_RGB0), "0.000000.png"),
        # inspect counted a frame whose listed file is gone; run stopped at it.
        ds_err(k, "rgb_listed_image_missing_inspect", rm(TUM_RGB2), ["rgb.txt", "0.066667.png"]),
        ds_err(k, "depth_txt_missing", rm("depth.txt"), "depth.txt"),
        ds_err(k, "depth_txt_stamps_far", lines("depth.txt", lambda d: ["%d %s" % (100 + i, x.split()[1])
                                                                          for i, x in enumerate(d)]), "depth.txt"),
        ds_err(k, "groundtruth_words", put("groundtruth.txt", "once upon a time\n"), "groundtruth.txt"),
        ds_err(k, "groundtruth_nan", field("groundtruth.txt", 1, 1, "nan"), "groundtruth.txt"),
        ds_err(k, "groundtruth_zero_quaternion",
               lines("groundtruth.txt", lambda d: [" ".join(d[0].split()[:4] + ["0", "0", "0", "0"])] + d[1:]),
               "groundtruth.txt"),
        ds_err(k, "groundtruth_quaternion_norm_2",
               lines("groundtruth.txt", lambda d: [" ".join(d[0].split()[:4] + ["0", "0", "0", "2"])] + d[1:]),
               "groundtruth.txt"),
        ds_err(k, "groundtruth_six_columns", lines("groundtruth.txt", lambda d: [" ".join(d[0].split()[:6])] + d[1:]),
               "groundtruth.txt"),
        ds_err(k, "calib_words", put("calib.txt", "focal length fifty\n"), "calib.txt"),
        ds_err(k, "calib_negative_focal", put("calib.txt", "-52.5 52.5 31.5 23.5\n"), "calib.txt"),
        ds_err(k, "calib_nan", put("calib.txt", "nan 52.5 31.5 23.5\n"), "calib.txt"),
        ds_err(k, "calib_five_numbers", put("calib.txt", "52.5 52.5 31.5 23.5 0.1\n"), "calib.txt"),
        ds_err(k, "calib_two_lines", put("calib.txt", "52.5 52.5 31.5 23.5\n52.5 52.5 31.5 23.5\n"), "calib.txt"),
        # Finite but absurd distortion looked every pixel up outside the image: black frames, an empty map.
        ds_err(k, "calib_absurd_distortion", put("calib.txt", "52.5 52.5 31.5 23.5 1e30 1e30 0 0 0\n"), "camera"),
        ds_err(k, "image_1x1_all", [put("rgb/%s.png" % t, png(1, 1)) for t in TUM_STAMPS]
               + [put("depth/%s.png" % t, png(1, 1, channels=1, bit_depth=16)) for t in TUM_STAMPS], "1x1", run=True),
        ds_err(k, "image_1x1_later", put(TUM_RGB2, png(1, 1)), "0.066667.png", run=True),
        ds_err(k, "image_truncated", trunc(TUM_RGB2, 0.5), "0.066667.png", run=True),
        ds_err(k, "image_empty", put(TUM_RGB2, b""), "0.066667.png", run=True),
        ds_err(k, "image_text", put(TUM_RGB2, "not an image\n"), "0.066667.png", run=True),
        ds_err(k, "image_bad_crc", put(TUM_RGB0, png_bad_crc_64x48), "0.000000.png"),
        ds_err(k, "image_zero_size", put(TUM_RGB0, png(0, 0, rows=0)), "0.000000.png"),
        ds_err(k, "image_other_size", put(TUM_RGB2, png(80, 60)), "0.066667.png", run=True),
        ds_err(k, "image_huge_declared_png", put(TUM_RGB0, png(60000, 60000, rows=1)), "0.000000.png",
               known=PNG_BOMB, quick=True),
        ds_err(k, "image_huge_declared_jpeg", put(TUM_RGB0, jpeg_header(60000, 60000)), "0.000000.png",
               known=PNG_BOMB),
        ds_err(k, "image_is_fifo", fifo(TUM_RGB2), "0.066667.png", run=True, timeout=30),
        ds_err(k, "image_is_folder", folder(TUM_RGB2), "0.066667.png", run=True),
        ds_err(k, "image_is_dev_zero", devzero(TUM_RGB0), "0.000000.png", timeout=30),
        ds_err(k, "depth_8bit", put(TUM_DEPTH2, png(64, 48, channels=1, bit_depth=8)), "0.066667.png", run=True,
               known=TUM_DEPTH8),
        ds_err(k, "depth_rgb", put(TUM_DEPTH2, png(64, 48, channels=3, bit_depth=16)), "0.066667.png", run=True),
        ds_err(k, "depth_other_size", put(TUM_DEPTH2, png(32, 24, channels=1, bit_depth=16)), "0.066667.png",
               run=True),
        ds_err(k, "depth_truncated", trunc(TUM_DEPTH2, 0.4), "0.066667.png", run=True),
        ds_err(k, "depth_huge_declared", put(TUM_DEPTH2, png(60000, 60000, channels=1, bit_depth=16, rows=1)),
               "0.066667.png", run=True, known=PNG_BOMB),
    ]
    return c


def png_bad_crc_64x48():
    return forge.png_bad_crc(64, 48)


KITTI_LEFT1, KITTI_RIGHT1 = "image_2/000001.png", "image_3/000001.png"


def kitti_cases():
    k = "kitti"
    fx_p3 = lambda d: d[:3] + [d[3].replace("5.250000000000e+01", "6.000000000000e+01", 1)] + d[4:]  # noqa: E731

    def p3(fn):
        return lines("calib.txt", lambda d: d[:3] + [fn(d[3])] + d[4:])
    c = [
        ok("ds.kitti.valid_inspect", INSPECT.format(kind=k), dataset(k), watch=["ds"], quick=True),
        ok("ds.kitti.valid_run", RUN_DS.format(kind=k), dataset(k), watch=["ds"]),
        ok("ds.street.valid_inspect", "inspect kitti:ds", dataset("street"), watch=["ds"]),
        # A stereo pair has its own baseline: the RGB-D flag was ignored unsaid.
        err("ds.kitti.track_rgbd_baseline_on_stereo", "track --dataset kitti:ds --out t.txt --rgbd-baseline 0.1",
            ["--rgbd-baseline", "stereo"], dataset(k), watch=["ds"]),
        # The estimate replaced the ground truth it was then scored against.
        err("ds.kitti.track_out_over_its_poses", "track --dataset kitti:ds --out ds/poses.txt --format kitti",
            "--out", dataset(k), watch=["ds"]),
        ds_err(k, "calib_missing", rm("calib.txt"), "calib.txt", quick=True),
        ds_err(k, "calib_empty", put("calib.txt", ""), "calib.txt"),
        ds_err(k, "calib_p2_eleven_numbers", lines("calib.txt", lambda d: d[:2] + [d[2].rsplit(" ", 1)[0]] + d[3:]),
               "calib.txt"),
        ds_err(k, "calib_p2_nan", lines("calib.txt", lambda d: d[:2] + [d[2].replace("5.250000000000e+01", "nan", 1)] + d[3:]),
               "calib.txt"),
        ds_err(k, "calib_p2_third_row", lines("calib.txt", lambda d: d[:2] + [d[2].rsplit(" ", 2)[0] + " 2 0"]
                                               + d[3:]), "calib.txt"),
        ds_err(k, "calib_p3_focal_differs", lines("calib.txt", fx_p3), "calib.txt", known=KITTI_FX),
        ds_err(k, "calib_p3_right_of_nothing", p3(lambda line: line.replace("-5.250000000000e+00", "0.0")),
               "calib.txt"),
        ds_err(k, "calib_p3_camera_to_the_left", p3(lambda line: line.replace("-5.250000000000e+00", "5.25")),
               "calib.txt"),
        ds_err(k, "calib_is_fifo", fifo("calib.txt"), "calib.txt", timeout=30),
        ds_err(k, "times_short", lines("times.txt", lambda d: d[:3]), "times.txt"),
        ds_err(k, "times_nan", field("times.txt", 2, 0, "nan"), "times.txt"),
        ds_err(k, "times_decreasing", lines("times.txt", lambda d: [d[1], d[0]] + d[2:]), "times.txt"),
        ds_err(k, "times_words", put("times.txt", "tick\ntock\n"), "times.txt"),
        ds_err(k, "poses_eleven_numbers", lines("poses.txt", lambda d: [d[0].rsplit(" ", 1)[0]] + d[1:]),
               "poses.txt"),
        ds_err(k, "poses_nan", field("poses.txt", 1, 3, "nan"), "poses.txt"),
        ds_err(k, "poses_scaled_rotation",
               lines("poses.txt", lambda d: [" ".join(str(2 * float(v)) if i % 4 != 3 else v
                                                       for i, v in enumerate(d[0].split()))] + d[1:]), "poses.txt"),
        ds_err(k, "poses_short", lines("poses.txt", lambda d: d[:2]), "poses.txt"),
        ds_err(k, "right_folder_missing", rm("image_3"), "image_3"),
        ds_err(k, "right_image_missing", rm(KITTI_RIGHT1), "image_3"),
        ds_err(k, "left_folder_empty", folder("image_2"), "image_2"),
        ds_err(k, "right_image_other_size", put(KITTI_RIGHT1, png(80, 60)), "000001.png", run=True),
        ds_err(k, "right_images_all_smaller",
               [put("image_3/%06d.png" % i, png(32, 24)) for i in range(8)], "image_3", run=True),
        ds_err(k, "left_image_truncated", trunc(KITTI_LEFT1, 0.5), "000001.png", run=True),
        ds_err(k, "left_image_gray_among_colour", put(KITTI_LEFT1, png(64, 48, channels=1)), "000001.png",
               run=True),
        ds_err(k, "left_image_huge_declared", put("image_2/000000.png", png(60000, 60000, rows=1)), "000000.png",
               known=PNG_BOMB),
    ]
    return c


def replica_cases():
    k = "replica"
    traj = lambda fn: lines("traj.txt", fn)  # noqa: E731
    c = [
        ok("ds.replica.valid_inspect", INSPECT.format(kind=k), dataset(k), watch=["ds"], quick=True),
        ok("ds.replica.valid_run", RUN_DS.format(kind=k), dataset(k), watch=["ds"]),
        ds_err(k, "cam_params_missing", rm("cam_params.json"), "frame000000.png"),
        ds_err(k, "cam_params_garbled", put("cam_params.json", '{"camera": {"w": 64,'), "cam_params.json"),
        ds_err(k, "cam_params_not_object", put("cam_params.json", "[1, 2, 3]"), "cam_params.json"),
        ds_err(k, "cam_params_w_string", sub("cam_params.json", '"w": 64', '"w": "64"'), "camera.w"),
        ds_err(k, "cam_params_fx_negative", sub("cam_params.json", '"fx": 52.5', '"fx": -52.5'), "fx"),
        # Finite but absurd: inspect took it, and run failed far away naming neither file nor field.
        ds_err(k, "cam_params_cx_huge", sub("cam_params.json", '"cx": 31.5', '"cx": 1e308'), ["cam_params.json", "principal point"]),
        ds_err(k, "cam_params_fx_huge", sub("cam_params.json", '"fx": 52.5', '"fx": 1e308'), ["cam_params.json", "focal"]),
        ds_err(k, "cam_params_w_huge", sub("cam_params.json", '"w": 64', '"w": 1e12'), "cam_params.json"),
        ds_err(k, "cam_params_scale_zero", sub("cam_params.json", '"scale": 5000.0', '"scale": 0'), "scale"),
        ds_err(k, "cam_params_cx_nan", sub("cam_params.json", '"cx": 31.5', '"cx": NaN'), "cam_params.json"),
        ds_err(k, "traj_missing", rm("traj.txt"), "traj.txt"),
        ds_err(k, "traj_short", traj(lambda d: d[:3]), "traj.txt"),
        ds_err(k, "traj_nan", field("traj.txt", 2, 3, "nan"), "traj.txt"),
        ds_err(k, "traj_fifteen_numbers", traj(lambda d: [d[0].rsplit(" ", 1)[0]] + d[1:]), "traj.txt"),
        ds_err(k, "traj_scaled_rotation", traj(lambda d: [" ".join(str(3 * float(v)) if i in (0, 5, 10) else v
                                                                    for i, v in enumerate(d[0].split()))] + d[1:]),
               "traj.txt"),
        ds_err(k, "depth_missing", rm("results/depth000003.png"), "frame000003"),
        ds_err(k, "results_empty", folder("results"), "results"),
        ds_err(k, "frame_huge_declared_jpeg", [rm("results/frame000000.png"), rm("results/frame000001.png"),
                                               put("results/frame000000.jpg", jpeg_header(60000, 60000))],
               "frame000000.jpg", known=PNG_BOMB),
        ds_err(k, "frame_jpeg_garbage", [rm("results/frame000000.png"),
                                         put("results/frame000000.jpg", b"\xff\xd8\xff\xe0garbage")],
               "frame000000.jpg"),
        ds_err(k, "frame_truncated", trunc("results/frame000002.png", 0.5), "frame000002.png", run=True),
    ]
    return c


def threedmatch_cases():
    k = "3dmatch"
    seq = "seq-01/"
    c = [
        ok("ds.3dmatch.valid_inspect", INSPECT.format(kind=k), dataset(k), watch=["ds"], quick=True),
        ds_err(k, "intrinsics_missing", rm("camera-intrinsics.txt"), "camera-intrinsics.txt"),
        ds_err(k, "intrinsics_two_rows", put("camera-intrinsics.txt", "52.5 0 31.5\n0 52.5 23.5\n"),
               "camera-intrinsics.txt"),
        ds_err(k, "intrinsics_not_pinhole", put("camera-intrinsics.txt", "52.5 0 31.5\n0 52.5 23.5\n0 0 2\n"),
               "camera-intrinsics.txt"),
        ds_err(k, "intrinsics_nan", put("camera-intrinsics.txt", "nan 0 31.5\n0 52.5 23.5\n0 0 1\n"),
               "camera-intrinsics.txt"),
        ds_err(k, "intrinsics_words", put("camera-intrinsics.txt", "a b c\nd e f\ng h i\n"), "camera-intrinsics.txt"),
        ds_err(k, "pose_missing_one", rm(seq + "frame-000003.pose.txt"), "frame-000003"),
        ds_err(k, "pose_garbled", put(seq + "frame-000002.pose.txt", "1 0 0\n"), "frame-000002.pose.txt"),
        ds_err(k, "pose_nan", put(seq + "frame-000002.pose.txt", "1 0 0 nan\n0 1 0 0\n0 0 1 0\n0 0 0 1\n"),
               "frame-000002.pose.txt"),
        ds_err(k, "pose_scaled_rotation", put(seq + "frame-000002.pose.txt", "2 0 0 0\n0 2 0 0\n0 0 2 0\n0 0 0 1\n"),
               "frame-000002.pose.txt"),
        ds_err(k, "pose_bottom_row", put(seq + "frame-000002.pose.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 5 1\n"),
               "frame-000002.pose.txt"),
        ds_err(k, "depth_missing", rm(seq + "frame-000004.depth.png"), "frame-000004.depth.png"),
        ds_err(k, "two_sequences", lambda root: forge.write(root / "seq-02" / "frame-000000.color.png", png(64, 48)),
               "seq-02"),
        ds_err(k, "depth_8bit", put(seq + "frame-000002.depth.png", png(64, 48, channels=1)),
               "frame-000002.depth.png", run=True),
    ]
    return c


def euroc_cases():
    k = "euroc"
    cam0, cam1 = "mav0/cam0/", "mav0/cam1/"
    y0 = cam0 + "sensor.yaml"
    c = [
        ok("ds.euroc.valid_inspect", INSPECT.format(kind=k), dataset(k), watch=["ds"], quick=True),
        ds_err(k, "sensor_yaml_missing", rm(y0), "sensor.yaml"),
        ds_err(k, "sensor_yaml_malformed", put(y0, "intrinsics: [1, 2\n"), "sensor.yaml"),
        ds_err(k, "intrinsics_three", sub(y0, "[52.5, 52.5, 31.5, 23.5]", "[52.5, 52.5, 31.5]"), "intrinsics"),
        ds_err(k, "intrinsics_word", sub(y0, "[52.5, 52.5, 31.5, 23.5]", "[fx, 52.5, 31.5, 23.5]"), "intrinsics"),
        ds_err(k, "resolution_zero", sub(y0, "resolution: [64, 48]", "resolution: [0, 48]"), "resolution"),
        ds_err(k, "resolution_huge", sub(y0, "resolution: [64, 48]", "resolution: [1e12, 48]"), "resolution"),
        ds_err(k, "resolution_wrong_for_images", [sub(y0, "resolution: [64, 48]", "resolution: [80, 48]"),
                                                  sub(cam1 + "sensor.yaml", "resolution: [64, 48]",
                                                      "resolution: [80, 48]")], "1000000000.png"),
        ds_err(k, "t_bs_scaled", sub(y0, "data: [1.0, 0.0, 0.0, 0, 0.0, 1.0", "data: [2.0, 0.0, 0.0, 0, 0.0, 2.0"),
               "T_BS"),
        ds_err(k, "distortion_model", sub(y0, "radial-tangential", "equidistant"), "equidistant"),
        ds_err(k, "distortion_absurd", sub(y0, "distortion_coefficients: [0.0, 0.0, 0.0, 0.0]",
                                           "distortion_coefficients: [1e30, 1e30, 0.0, 0.0]"), "sensor.yaml"),
        ds_err(k, "rate_word", sub(y0, "rate_hz: 20", "rate_hz: fast"), "sensor.yaml"),
        ds_err(k, "rate_zero", sub(y0, "rate_hz: 20", "rate_hz: 0"), "rate_hz"),
        ds_err(k, "data_csv_word", field(cam0 + "data.csv", 1, 0, "soon,1050000000.png"), "data.csv"),
        ds_err(k, "data_csv_negative", sub(cam0 + "data.csv", "1050000000,", "-1050000000,"), "data.csv"),
        ds_err(k, "data_csv_missing_image", sub(cam0 + "data.csv", "1100000000.png", "1100000001.png"),
               "1100000001.png"),
        ds_err(k, "data_csv_is_fifo", fifo(cam0 + "data.csv"), "data.csv", timeout=30),
        ds_err(k, "cam1_resolution_differs", sub(cam1 + "sensor.yaml", "resolution: [64, 48]",
                                                 "resolution: [32, 24]"), "cam1"),
        ds_err(k, "cam1_to_the_left", sub(cam1 + "sensor.yaml", "data: [1.0, 0.0, 0.0, 0.1",
                                          "data: [1.0, 0.0, 0.0, -0.1"), "cam1"),
        ds_err(k, "cam1_missing", rm("mav0/cam1"), "cam1"),
        ds_err(k, "groundtruth_two_files", put("groundtruth/other.txt", "0 0 0 0 0 0 0 1\n"), "groundtruth"),
        ds_err(k, "groundtruth_nan", field("groundtruth/gt.txt", 1, 2, "nan"), "gt.txt"),
        ds_err(k, "image_huge_declared", put(cam0 + "data/1000000000.png", png(60000, 60000, rows=1)),
               "1000000000.png", known=PNG_BOMB),
    ]
    return c


def street_spec_cases():
    c = []
    for name, spec, word in [
        ("length_word", "length=far", "far"),
        ("length_negative", "length=-5", "length"),
        ("length_nan", "length=nan", "length"),
        ("length_inf", "length=inf", "length"),
        ("length_too_long", "length=1e7", "length"),
        ("length_hex", "length=0x10", "length"),
        ("width_zero", "length=12,width=0,height=0", "0x0"),
        ("width_only", "length=12,width=64", "height"),
        ("width_negative", "length=12,width=-64,height=48", "width"),
        ("width_huge", "length=12,width=99999,height=48", "width"),
        ("seed_negative", "length=12,seed=-1", "seed"),
        ("frames_word", "length=12,frames=many", "frames"),
        ("depth_two", "length=12,depth=2", "depth"),
        ("unknown_key", "length=12,colour=red", "colour"),
        ("key_twice", "length=12,length=13", "length"),
        ("empty_item", "length=12,,seed=1", "key=value"),
        ("no_value", "length", "length"),
    ]:
        c.append(err("ds.street_spec." + name, RUN + " --dataset synth-street:%s --out out" % spec, word,
                     quick=name == "length_word"))
    # frames is a most: a street shorter than that gave fewer frames without a word.
    c.append(Case("ds.street_spec.frames_beyond_the_street", "inspect synth-street:length=12,frames=1000",
                  "error_or_warning", ["frames"]))
    return c


# ---------------------------------------------------------------------------------------------
# Map folders: the readers (export, render) must leave them as they are; --resume must refuse a
# damaged one naming the file, and leave it too.

EXPORT = "export --map map --out x.ply"
RENDER = "render --map map --poses traj.txt --out r"
# A map remembers the dataset it was made from (the seed's tum:tum) and refuses to resume on another.
RESUME = RUN + " --dataset tum:tum --out map --resume"


def reader(name, damage, says, known=None, quick=False, render=True, export=True):
    """The same damage read by export and by render."""
    damage = damage if isinstance(damage, (list, tuple)) else [damage]
    out = []
    if export:
        out.append(err("map.export." + name, EXPORT, says, a_map(*damage), watch=["map"], known=known, quick=quick))
    if render:
        out.append(err("map.render." + name, RENDER, says, both(a_map(*damage), seed("traj_tum.txt", "traj.txt")),
                       watch=["map"], known=known))
    return out


def resume(name, damage, says, known=None, quick=False, expect="error", **kw):
    damage = damage if isinstance(damage, list) else [damage]
    case = err("map.resume." + name, RESUME, says, both(a_map(*damage, name="map_half"), seed("tum")),
               watch=["map", "tum"], known=known, quick=quick, **kw)
    case.expect = expect
    return case


def json_key(key, value):
    """run_state.json with one key's value replaced (json text, so any type fits)."""
    import json

    def damage(root):
        state = json.loads((root / "run_state.json").read_text())
        if value is None:
            state.pop(key)
        else:
            state[key] = json.loads(value)
        forge.write(root / "run_state.json", json.dumps(state))
    return damage


def keyframes_field(index, value):
    return field("keyframes.txt", 0, index, value)


def map_cases():
    c = [
        ok("map.export.valid", EXPORT, a_map(), watch=["map"], quick=True),
        ok("map.render.valid", RENDER, both(a_map(), seed("traj_tum.txt", "traj.txt")), watch=["map"]),
        ok("map.render.valid_dataset", "render --map map --dataset tum:ds --out r", both(a_map(), dataset("tum")),
           watch=["map", "ds"]),
        ok("map.resume.valid", RESUME, both(a_map(name="map_half"), seed("tum")), watch=["tum"]),
        # A reader reads the last commit beside a running writer (README, "Readers and a running mapper").
        ok("map.export.lock_held_by_a_writer", EXPORT, a_map(), watch=["map"], hold_lock="map/lock"),
        # The PNGs go beside the map by default (MAP-renders), never into it.
        ok("map.render.default_out_beside_map", "render --map map --poses traj.txt",
           both(a_map(), seed("traj_tum.txt", "traj.txt")), watch=["map"], known=RENDER_OUT),
        err("map.render.out_inside_map", "render --map map --poses traj.txt --out map/r", "map",
            both(a_map(), seed("traj_tum.txt", "traj.txt")), watch=["map"], known=RENDER_OUT),
        err("map.export.out_inside_map", "export --map map --out map/x.ply", "map", a_map(), watch=["map"]),
        err("map.export.out_is_manifest", "export --map map --out map/manifest.txt", "map", a_map(), watch=["map"]),
        err("map.export.out_is_the_map", "export --map map --out map", "map", a_map(), watch=["map"]),
        err("map.export.map_missing", EXPORT, "map"),
        err("map.export.map_is_a_file", EXPORT, "map", file_in("map", "x\n")),
        err("map.export.empty_folder", EXPORT, "manifest", lambda d, s: (d / "map").mkdir(), watch=["map"]),
        err("map.resume.lock_held", RESUME, "already open", both(a_map(name="map_half"), seed("tum")),
            watch=["map"], hold_lock="map/lock"),
        err("map.resume.lock_is_folder", RESUME, "lock", both(a_map(folder("lock"), name="map_half"), seed("tum")),
            watch=["map"]),
        err("map.run.existing_map_without_resume", RUN + " --dataset tum:ds --out map", "--resume",
            both(a_map(), dataset("tum")), watch=["map"]),
        # Nothing to continue: --resume starts the run (a run killed before its first checkpoint).
        ok("map.resume.empty_folder", RESUME, both(lambda d, s: (d / "map").mkdir(), seed("tum"))),
        err("map.resume.other_dataset", RUN + " --dataset kitti:ds --out map --resume", "kitti:ds",
            both(a_map(name="map_half"), dataset("kitti")), watch=["map"]),
        # Frames held out by one rule and trained by the other were scored as never seen.
        err("map.resume.other_holdout", RESUME + " --config h.yaml", "holdout_every",
            both(a_map(name="map_half"), seed("tum"), file_in("h.yaml", "mapper: {holdout_every: 2}\n")),
            watch=["map"]),
    ]
    c += reader("manifest_missing", rm("manifest.txt"), "manifest", quick=True)
    c += reader("manifest_empty", put("manifest.txt", ""), "manifest.txt")
    c += reader("manifest_flipped_byte", flip("manifest.txt", 40), "manifest.txt")
    c += reader("manifest_truncated", trunc("manifest.txt", 0.6), "manifest.txt")
    c += reader("manifest_is_folder", folder("manifest.txt"), "manifest.txt")
    c += reader("manifest_is_fifo", fifo("manifest.txt"), "manifest.txt", render=False)
    c += reader("manifest_is_dev_zero", devzero("manifest.txt"), "manifest.txt", render=False)
    c += reader("manifest_chunk_size_negative", manifest(lambda b: b.replace("chunk_size 10", "chunk_size -1")),
                "chunk_size")
    c += reader("manifest_chunk_size_nan", manifest(lambda b: b.replace("chunk_size 10", "chunk_size nan")),
                "chunk_size")
    c += reader("manifest_sh_degree_9", manifest(lambda b: b.replace("sh_degree 3", "sh_degree 9")), "sh_degree")
    c += reader("manifest_version_99", manifest(lambda b: b.replace("diskchungs-manifest 2",
                                                                     "diskchungs-manifest 99")), "version")
    c += reader("manifest_unknown_entry", manifest(lambda b: b + "colour blue\n"), "colour")
    c += reader("manifest_count_huge", manifest(manifest_chunk_field(2, "18446744073709551615")), "manifest.txt")
    c += reader("manifest_count_differs", manifest(manifest_chunk_field(2, "7")), "chunk")
    c += reader("manifest_chunk_id_bad", manifest(manifest_chunk_field(1, "zz")), "zz")
    c += reader("manifest_chunk_not_on_disk", manifest(lambda b: b.replace("chunk 4", "chunk 5", 1)), "chunk")
    c += reader("manifest_file_size_differs", manifest(manifest_chunk_field(3, "12")), "chunk")
    c += reader("manifest_generation_word", manifest(manifest_chunk_field(5, "next")), "generation")
    c += reader("chunk_missing", chunk(forge.remove), ".chunk")
    c += reader("chunk_empty", chunk(lambda p: p.write_bytes(b"")), ".chunk")
    c += reader("chunk_truncated", chunk(lambda p: forge.truncate(p, 0.5)), ".chunk")
    c += reader("chunk_payload_flipped", chunk(lambda p: forge.flip_byte(p, 500)), ".chunk")
    c += reader("chunk_header_flipped", chunk(lambda p: forge.flip_byte(p, 20)), ".chunk")
    c += reader("chunk_is_folder", chunk(forge.make_dir), ".chunk")
    c += reader("chunk_is_dev_zero", chunk(lambda p: forge.link_to(p, "/dev/zero")), ".chunk", render=False)
    c += reader("chunk_mislabelled", chunk(lambda p: forge.resign_chunk(p, id=forge.chunk_header(p)["id"] + 1)),
                ".chunk")
    c += reader("chunk_version_9", chunk(lambda p: forge.resign_chunk(p, version=9)), "version")
    c += reader("chunk_count_huge", chunk(lambda p: forge.resign_chunk(
        p, payload=b"\x28\xb5\x2f\xfd" + b"\0" * 60, count=1 << 28, flags=forge.chunk_header(p)["flags"] | 1,
        raw=forge.chunk_payload_bytes(1 << 28, forge.chunk_header(p)["flags"]))), ".chunk", known=STORE_HEADER)
    c += reader("chunk_sh_degree_differs", chunk(lambda p: forge.resign_chunk(p, sh=1)), ".chunk")
    c += reader("keyframes_txt_words", put("keyframes.txt", "first second third\n"), "keyframes.txt", export=False)
    c += reader("keyframes_txt_empty", put("keyframes.txt", ""), ["keyframes.txt", "lists no keyframe"], export=False)
    c += reader("keyframes_width_nan", keyframes_field(3, "nan"), "keyframes.txt", export=False)
    c += reader("keyframes_width_zero", keyframes_field(3, "0"), "keyframes.txt", export=False)
    c += reader("keyframes_width_huge", [keyframes_field(3, "1000000"), keyframes_field(4, "1000000")],
                "keyframes.txt", export=False)
    c += reader("keyframes_fx_negative", keyframes_field(5, "-52.5"), "keyframes.txt", export=False)
    c += reader("keyframes_zero_quaternion", [keyframes_field(i, "0") for i in range(12, 16)], "keyframes.txt",
                export=False)
    c += reader("report_garbled", put("report.json", "{\"settings\": "), "report.json", export=False)
    c += reader("report_budget_string", put("report.json", '{"settings": {"budget_gaussians": "many"}}'),
                "report.json", export=False)
    c += reader("report_budget_negative", put("report.json", '{"settings": {"budget_gaussians": -5}}'),
                "report.json", export=False)
    c += reader("sky_garbage", put("sky.bin", "not a sky\n"), "sky.bin", export=False)

    c += [
        resume("run_state_missing", rm("run_state.json"), "run_state.json", quick=True),
        resume("run_state_empty", put("run_state.json", ""), "run_state.json"),
        resume("run_state_garbled", put("run_state.json", '{"next_frame": 4,'), "run_state.json"),
        resume("run_state_array", put("run_state.json", "[1, 2, 3]"), "run_state.json"),
        resume("next_frame_negative", json_key("next_frame", "-3"), "next_frame"),
        resume("next_frame_string", json_key("next_frame", '"four"'), "next_frame"),
        resume("next_frame_huge", json_key("next_frame", "1e30"), "next_frame"),
        resume("next_frame_beyond_dataset", json_key("next_frame", "100"), "next_frame"),
        resume("next_frame_missing", json_key("next_frame", None), "next_frame"),
        resume("finished_string", json_key("finished", '"no"'), "finished"),
        resume("rng_garbage", json_key("rng", '"dice"'), "rng"),
        resume("keyframe_chunks_list", json_key("keyframe_chunks", "[1, 2]"), "keyframe_chunks"),
        resume("timeline_number", json_key("timeline", "7"), "timeline"),
        resume("keyframes_txt_missing", rm("keyframes.txt"), "keyframes.txt"),
        resume("keyframes_txt_words", put("keyframes.txt", "first second third\n"), "keyframes.txt"),
        resume("keyframes_txt_nan_pose", keyframes_field(9, "nan"), "keyframes.txt"),
        resume("keyframe_file_missing", rm("keyframes/1.keyframe"), ("1.keyframe", "keyframe 1")),
        resume("keyframe_file_flipped", flip("keyframes/1.keyframe", 200), "1.keyframe"),
        resume("keyframe_file_truncated", trunc("keyframes/1.keyframe", 0.5), "1.keyframe"),
        resume("keyframe_file_huge_declared",
               lambda root: forge.resign_keyframe(root / "keyframes/1.keyframe", cw=32768, ch=32768, cc=4, dw=32768,
                                                  dh=32768, dc=1, raw=32768 * 32768 * 8), "1.keyframe",
               known=STORE_HEADER),
        resume("manifest_flipped", flip("manifest.txt", 30), "manifest.txt"),
        # A manifest that is a link in a loop was called missing, and --resume rebuilt one over the link.
        resume("manifest_link_loop", [rm("manifest.txt"), lambda root: forge.link_to(root / "manifest.txt",
                                                                                      "manifest.txt")],
               "manifest.txt"),
        # A writer may repair a map, but never without naming what it dropped.
        resume("chunk_missing", chunk(forge.remove), ".chunk", expect="error_or_warning"),
        resume("chunk_payload_flipped", chunk(lambda p: forge.flip_byte(p, 500)), ".chunk"),
        resume("chunk_count_huge", chunk(lambda p: forge.resign_chunk(
            p, payload=b"\x28\xb5\x2f\xfd" + b"\0" * 60, count=1 << 28, flags=forge.chunk_header(p)["flags"] | 1,
            raw=forge.chunk_payload_bytes(1 << 28, forge.chunk_header(p)["flags"]))), ".chunk", known=STORE_HEADER),
        # A new map into a folder of the user's files (one named as a run's trajectory.txt): refused, left as it was.
        err("map.run.out_holds_other_files", RUN + " --dataset tum:ds --out mine", ["mine", "notes.md"],
            both(dataset("tum"), lambda d, s: [forge.write(d / "mine" / f, "keep") for f in ("notes.md", "trajectory.txt")]),
            watch=["mine", "ds"], quick=True),
    ]
    return c


# ---------------------------------------------------------------------------------------------
# Trajectories: eval ate's two files and render --poses.


def trajectory_cases():
    c = []
    ate = "eval ate --gt gt.txt --est est.txt"
    gt = seed("traj_tum.txt", "gt.txt")
    c.append(ok("traj.ate_valid", ate, both(gt, seed("traj_tum.txt", "est.txt")), quick=True))
    c.append(ok("traj.ate_kitti_valid", "eval ate --gt gt.txt --est est.txt",
                both(seed("traj_kitti.txt", "gt.txt"), seed("traj_kitti.txt", "est.txt"))))
    # A read-only command: --plot named like its input wrote a PNG over the trajectory.
    both_files = both(gt, seed("traj_tum.txt", "est.txt"))
    c.append(err("traj.ate_plot_over_its_input", ate + " --plot est.txt", ("--plot", "est.txt"), both_files,
                 watch=["est.txt"]))
    c.append(err("traj.ate_plot_over_a_text_file", ate + " --plot notes.txt", "notes.txt",
                 both(both_files, file_in("notes.txt", "my notes\n")), watch=["notes.txt"]))

    def est(fn):
        def setup(d, s):
            s.copy("traj_tum.txt", d / "gt.txt")
            s.copy("traj_tum.txt", d / "est.txt")
            fn(d / "est.txt")
        return setup

    quat = lambda q: lambda p: forge.edit_lines(p, lambda d: [" ".join(d[0].split()[:4] + q)] + d[1:])  # noqa: E731
    table = [
        ("empty", lambda p: forge.write(p, "")),
        ("comments_only", lambda p: forge.write(p, "# nothing\n")),
        ("words", lambda p: forge.write(p, "the quick brown fox\n")),
        ("nan", lambda p: forge.edit_field(p, 2, 1, "nan")),
        ("inf", lambda p: forge.edit_field(p, 2, 2, "inf")),
        ("seven_fields", lambda p: forge.edit_lines(p, lambda d: [" ".join(d[0].split()[:7])] + d[1:])),
        ("zero_quaternion", quat(["0", "0", "0", "0"])),
        ("quaternion_norm_3", quat(["0", "0", "0", "3"])),
        ("stamps_decreasing", lambda p: forge.edit_lines(p, lambda d: [d[2], d[1], d[0]] + d[3:])),
        ("stamps_repeated", lambda p: forge.edit_field(p, 1, 0, "0")),
        ("stamp_nan", lambda p: forge.edit_field(p, 1, 0, "nan")),
        ("one_pose", lambda p: forge.edit_lines(p, lambda d: d[:1])),
        ("mixed_formats", lambda p: forge.edit_lines(p, lambda d: d + [" ".join(["1", "0", "0", "0", "0", "1", "0",
                                                                              "0", "0", "0", "1", "0"])])),
        ("is_fifo", forge.make_fifo),
        ("is_folder", forge.make_dir),
        ("is_dev_zero", lambda p: forge.link_to(p, "/dev/zero")),
        ("binary", lambda p: forge.write(p, bytes(range(256)) * 4)),
    ]
    for name, fn in table:
        c.append(err("traj.ate_est_" + name, ate, "est.txt", est(fn), timeout=30))
    kitti_scaled = lambda p: forge.edit_lines(p, lambda d: [  # noqa: E731
        " ".join(str(2 * float(v)) if i % 4 != 3 else v for i, v in enumerate(d[0].split()))] + d[1:])
    c.append(err("traj.ate_kitti_scaled_rotation", ate, "est.txt",
                 both(seed("traj_kitti.txt", "gt.txt"), seed("traj_kitti.txt", "est.txt"),
                      lambda d, s: kitti_scaled(d / "est.txt"))))
    c.append(err("traj.ate_no_overlap", ate, "est.txt", est(lambda p: forge.edit_lines(
        p, lambda d: ["%s %s" % (float(x.split()[0]) + 1000, " ".join(x.split()[1:])) for x in d]))))
    c.append(err("traj.ate_gt_missing", ate, "gt.txt", seed("traj_tum.txt", "est.txt")))

    def render_poses(fn):
        def setup(d, s):
            s.copy("map", d / "map")
            s.copy("traj_tum.txt", d / "traj.txt")
            fn(d / "traj.txt")
        return setup
    for name, fn in table[:7] + [("kitti_scaled_rotation", None), ("is_fifo", forge.make_fifo)]:
        if fn is None:
            setup = both(a_map(), seed("traj_kitti.txt", "traj.txt"), lambda d, s: kitti_scaled(d / "traj.txt"))
        else:
            setup = render_poses(fn)
        c.append(err("traj.render_poses_" + name, RENDER, "traj.txt", setup, watch=["map"], timeout=30))
    return c


def png_size(path):
    """Width and height from a PNG's header."""
    head = path.read_bytes()[16:24]
    return int.from_bytes(head[:4], "big"), int.from_bytes(head[4:], "big")


def image_set_cases():
    c = []
    cmd = "eval images --ref ref --test test"
    sets = both(seed("images_ref", "ref"), seed("images_test", "test"))
    c.append(ok("images.valid", cmd, sets, quick=True))
    for name, damage, word in [
        ("test_missing_folder", lambda d, s: forge.remove(d / "test"), "test"),
        ("test_empty_folder", lambda d, s: forge.make_dir(d / "test"), "test"),
        ("test_other_size", lambda d, s: forge.write(d / "test/1.png", png(32, 24)), "1.png"),
        ("test_truncated", lambda d, s: forge.truncate(d / "test/1.png", 0.5), "1.png"),
        ("test_text", lambda d, s: forge.write(d / "test/1.png", "pixels\n"), "1.png"),
        ("test_gray_vs_colour", lambda d, s: forge.write(d / "test/1.png", png(64, 48, channels=1)), "1.png"),
        ("test_huge_declared", lambda d, s: forge.write(d / "test/1.png", png(60000, 60000, rows=1)), "1.png"),
        ("test_is_fifo", lambda d, s: forge.make_fifo(d / "test/1.png"), "1.png"),
        ("ref_is_dev_zero", lambda d, s: forge.link_to(d / "ref/0.png", "/dev/zero"), "0.png"),
        ("mask_other_size", lambda d, s: forge.write(d / "mask.png", png(32, 24, channels=1)), "mask"),
        # A mask of zeros scores no pixel: PSNR and SSIM were printed as nan with exit 0.
        ("mask_all_zero", lambda d, s: forge.write(d / "mask.png", png(*png_size(d / "ref/0.png"), channels=1, fill=0)),
         "mask.png"),
    ]:
        extra = " --mask mask.png" if name.startswith("mask") else ""
        known = PNG_BOMB if "huge" in name else None
        c.append(err("images." + name, cmd + extra, word, both(sets, damage), timeout=30, known=known))
    return c


def all_cases():
    return (cli_cases() + number_cases() + synth_cases() + config_cases() + tum_cases() + kitti_cases()
            + replica_cases() + threedmatch_cases() + euroc_cases() + street_spec_cases() + map_cases()
            + trajectory_cases() + image_set_cases())
