"""Motion-capture retrieval and synthesis from Python (docs/python.md).

    import mocap
    index = mocap.Index("set1.h5")
    walk = index.find_clips(content="walk")[0]
    walk.joint_positions                  # (F, J, 3) float32, metres, no copy
    out = index.search({"id": "q", "frames": [...]})   # mocap-search's output line, as a dict
    motion = index.synthesize({"id": "q", "frames": [...]})
    motion.write_bvh("motion.bvh")

Arrays an index holds are read-only numpy views of the index's memory (they
keep the index open); arrays computed on the fly are new float64 arrays.
Quaternions are (w, x, y, z); lengths are metres unless a name says file
units; the world is Y up. Bad input raises mocap.InputError (a ValueError
with .source, .line and .detail).
"""

import fnmatch
import json
import os
import tempfile

import numpy as np

from . import _mocap
from ._mocap import InputError

__version__ = _mocap.__version__

__all__ = [
    "Bvh",
    "Clip",
    "Index",
    "InputError",
    "Skeleton",
    "Synthesis",
    "parse_bvh",
    "read_bvh",
    "recognise_style",
    "write_bvh",
]


def _json_default(value):
    # Numbers and lists from numpy, paths: what a notebook hands a query.
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def _query_text(query):
    """A query as JSON text: a dict (dumped) or a JSON string (as is)."""
    if isinstance(query, str):
        return query
    if not isinstance(query, dict):
        raise TypeError(f"a query is a dict or a JSON string, got {type(query).__name__}")
    return json.dumps(query, default=_json_default)


def _with_results_file(results, run):
    """run(path) with the search results as a JSONL file: None or a path as
    given, dicts (search()'s lines) written to a temporary file."""
    if results is None or isinstance(results, (str, os.PathLike)):
        return run(results)
    lines = results if isinstance(results, (list, tuple)) else [results]
    with tempfile.TemporaryDirectory(prefix="mocap-") as tmp:
        path = os.path.join(tmp, "results.jsonl")
        with open(path, "w", encoding="utf-8") as f:
            for line in lines:
                f.write(json.dumps(line) + "\n")
        return run(path)


def _input_error(failure):
    """A mocap.InputError from a failed batch item's fields."""
    error = InputError(failure["message"])
    error.source = failure["source"]
    error.line = failure["line"]
    error.detail = failure["detail"]
    return error


def _style_model_text(model):
    """A style model (a dict, or a model file's path; None: none) as JSON text."""
    if model is None:
        return ""
    if isinstance(model, (str, os.PathLike)):
        with open(model, encoding="utf-8") as f:
            return f.read()
    return json.dumps(model)


def _base_dir(base_dir):
    return os.fspath(base_dir) if base_dir is not None else os.getcwd()


class Skeleton:
    """One skeleton of an index: its joint table and its clips.

    joint_names (J names), parents ((J,) int32, -1 for a root, parents before
    children), offsets_m ((J, 3) rest translation from the parent, metres),
    end_sites_m ((J, 3); has_end_site (J,) bool), channels (per joint the BVH
    channels as in the files), root_joint (the pelvis, whose world position is
    root_position_m), segments (joints with mass: the rows of segment arrays),
    masses_kg ((J,) per joint, the index's character), frame_count.
    """

    def __init__(self, index, number):
        self._index = index
        table = index._raw.skeleton(number)
        self.number = number
        self.id = table["id"]
        self.joint_names = table["joint_names"]
        self.parents = table["parents"]
        self.offsets_m = table["offsets_m"]
        self.end_sites_m = table["end_sites_m"]
        self.has_end_site = table["has_end_site"]
        self.translation_scales = table["translation_scales"]
        self.channels = table["channels"]
        self.unit_scale_m = table["unit_scale_m"]
        self.root_joint = table["root_joint"]
        self.segments = table["segments"]
        self.masses_kg = table["masses_kg"]
        self.total_mass_kg = table["total_mass_kg"]
        self.frame_count = table["frame_count"]
        self._clip_numbers = table["clips"]

    @property
    def joint_count(self):
        return len(self.joint_names)

    @property
    def clips(self):
        """The clips of this skeleton, in row order."""
        return [self._index.clips[c] for c in self._clip_numbers]

    def joint(self, name):
        """The index of joint `name` (exact name)."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise KeyError(f"no joint {name!r} (joints: {', '.join(self.joint_names)})") from None

    def frames(self, field):
        """Every frame of the skeleton (all its clips, in row order) of a
        per-frame field (Index.fields()): a read-only (N, ...) view."""
        return self._index._raw.array(self.number, "frames", field)

    def array(self, group, field):
        """Any array of the skeleton: group frames, blocks16, blocks64 or clip_bounds."""
        return self._index._raw.array(self.number, group, field)

    def __repr__(self):
        return (f"<mocap.Skeleton {self.number}: {self.joint_count} joints, "
                f"{len(self._clip_numbers)} clips, {self.frame_count} frames>")


class Clip:
    """One clip of an index: its record and its per-frame arrays.

    number (its place in the index, a search result's clip_index), path (the
    file as indexed), name (file name), stem, labels ({"content": ..,
    "style": ..} for the labels it has), frame_count, frame_time_s, fps,
    times ((F,) seconds from the first frame), skeleton (a Skeleton), unit and
    unit_scale_m (the file's length unit). Frame arrays are read-only views
    of the index (float32; energy_prefix_J float64), loaded on first use.
    """

    def __init__(self, index, record):
        self._index = index
        self.number = record["number"]
        self.path = record["path"]
        self.name = os.path.basename(self.path)
        self.stem = os.path.splitext(self.name)[0]
        self.labels = record["labels"]
        self.frame_count = record["frame_count"]
        self.frame_time_s = record["frame_time_s"]
        self.unit = record["unit"]
        self.unit_scale_m = record["unit_scale_m"]
        self.skeleton_number = record["skeleton"]
        self.frame_start = record["frame_start"]
        self.record = record

    @property
    def content(self):
        return self.labels.get("content", "")

    @property
    def style(self):
        return self.labels.get("style", "")

    @property
    def fps(self):
        return 1.0 / self.frame_time_s

    @property
    def times(self):
        return np.arange(self.frame_count) * self.frame_time_s

    @property
    def skeleton(self):
        return self._index.skeletons[self.skeleton_number]

    def frames(self, field):
        """The clip's rows of a per-frame field (Index.fields()): (F, ...)."""
        return self._index._raw.clip_frames(self.number, field)

    @property
    def root_positions(self):
        """(F, 3) world position of the root joint (the pelvis), metres."""
        return self.frames("root_position_m")

    @property
    def joint_positions(self):
        """(F, J, 3) world joint origins, metres."""
        return self.frames("joint_positions_m")

    @property
    def local_rotations(self):
        """(F, J, 4) joint rotations relative to the parent, (w, x, y, z)."""
        return self.frames("local_rotations")

    @property
    def world_rotations(self):
        """(F, J, 4) joint frames in world (world from joint), (w, x, y, z)."""
        return self.frames("world_rotations")

    @property
    def energy_prefix_J(self):
        """(F,) the clip's own energy prefix sums: frames s..e cost P[e] - P[s] joules."""
        return self.frames("energy_prefix_J")

    def __repr__(self):
        labels = ", ".join(f"{k}={v}" for k, v in self.labels.items())
        return (f"<mocap.Clip {self.number} {self.name}: {self.frame_count} frames at "
                f"{self.fps:g} fps{', ' + labels if labels else ''}>")


class Index:
    """An index file built by `mocap-index build`, opened read-only.

    clips (list of Clip, index order), skeletons (list of Skeleton), info
    (the root attributes; info["character"] the character as a dict),
    label_keys, labels ({key: sorted values}), frame_count, skipped (files
    the build did not index, with why).
    """

    def __init__(self, path, verify=False):
        self._raw = _mocap.Index(os.fspath(path), verify)
        self._clips = None
        self._skeletons = None

    @property
    def path(self):
        return self._raw.path

    @property
    def info(self):
        info = self._raw.info()
        info["character"] = json.loads(info.pop("character_json") or "null")
        return info

    @property
    def label_keys(self):
        return self._raw.label_keys

    @property
    def frame_count(self):
        return self._raw.frame_count

    @property
    def clips(self):
        if self._clips is None:
            self._clips = [Clip(self, r) for r in self._raw.clips()]
        return self._clips

    @property
    def skeletons(self):
        if self._skeletons is None:
            self._skeletons = [Skeleton(self, k) for k in range(self._raw.skeleton_count)]
        return self._skeletons

    @property
    def skipped(self):
        return self._raw.skipped()

    @property
    def labels(self):
        """{label key: sorted list of the labels clips have}."""
        out = {k: set() for k in self.label_keys}
        for c in self.clips:
            for k, v in c.labels.items():
                out.setdefault(k, set()).add(v)
        return {k: sorted(v) for k, v in out.items()}

    @staticmethod
    def fields(group="frames"):
        """The fields of a group (frames, blocks16, blocks64, clip_bounds):
        name, dtype, unit, description and stored (False: not in an index
        file of the current schema, derived on load; docs/index-format.md
        "Versions")."""
        return _mocap.Index.fields(group)

    def clip(self, key):
        """A clip by number, by path as indexed, by file name or by stem."""
        if isinstance(key, (int, np.integer)):
            return self.clips[int(key)]
        key = os.fspath(key)
        for c in self.clips:
            if key in (c.path, c.name, c.stem):
                return c
        raise KeyError(f"no clip {key!r} in {self.path}")

    def find_clips(self, content=None, style=None, name=None):
        """The clips whose labels and file name match: content / style a
        label or a list of labels (any of them), name a shell glob on the
        file name."""
        def accepts(value, wanted):
            if wanted is None:
                return True
            return value in ([wanted] if isinstance(wanted, str) else list(wanted))
        return [c for c in self.clips
                if accepts(c.content, content) and accepts(c.style, style)
                and (name is None or fnmatch.fnmatchcase(c.name, name))]

    def style_model(self, *, shrinkage=0.3, evaluate=False, folds=0):
        """The style model `mocap-index style-model` learns from this index's
        clips labelled with a content and a style (docs/style.md), as a
        dict: json.dump it to a file for `mocap-search style --model`, or
        pass it to mocap.recognise_style. With evaluate=True, returns
        (model, evaluation): the cross-validation of --evaluate (folds 0:
        leave one take out) as its --json prints it."""
        out = json.loads(self._raw.style_model(shrinkage, evaluate, folds))
        return (out["model"], out["evaluation"]) if evaluate else out["model"]

    def search(self, queries, *, base_dir=None, mode="exact", min_length_s=0.2,
               max_length_s=4.0, checks=256, trees=4, recall=True, threads=0,
               style_model=None):
        """Answers queries (docs/queries.md) on the shared search engine.

        `queries`: one query (a dict or JSON text) or a list of them. Returns,
        per query, mocap-search's output line as a dict: {"id", "pairs":
        [{"from", "to", "results": [{"rank", "clip", "clip_index", "labels",
        "start_frame", "end_frame", "score_J", "h_in_J", "h_out_J",
        "path_cost_J", ...}]}], "stats": {...}}. One query (a dict or a
        string): its dict, or mocap.InputError raised when it cannot be
        answered. A list: a list in order, where a query that could not be
        answered gets mocap-search's error line {"id", "error"} and the
        others are still answered. Relative "bvh" / "character" paths
        resolve against base_dir (default: the current folder). The options
        are mocap-search's (--mode, --min-length, --max-length, --checks,
        --trees, --no-recall, --threads; threads=0: all cores). style_model
        (a dict from style_model() or a model file's path): every result
        also gets "recognised_style": {"label", "p"}, as with --style-model
        (docs/style.md).
        """
        single = not isinstance(queries, (list, tuple))
        texts = [_query_text(q) for q in ([queries] if single else queries)]
        if isinstance(style_model, (str, os.PathLike)):
            with open(style_model, encoding="utf-8") as f:
                style_model = json.load(f)
        lines = self._raw.search(texts, _base_dir(base_dir), mode, min_length_s, max_length_s,
                                 checks, trees, recall, threads, raise_errors=single,
                                 style_model=json.dumps(style_model) if style_model else "")
        out = [json.loads(line) for line in lines]
        return out[0] if single else out

    def synthesize(self, query, *, results=None, picks=(), method="astar", max_states=60,
                   cost_threshold_J=5.0, step_feet=False, fps=None, refine=0,
                   refine_smoothing_J=0.0, refine_polish=0, refine_polish_window=1,
                   refine_polish_segments=False, refine_polish_smoothing_J=0.0, threads=0,
                   base_dir=None, energy="w", warp=None, warp_candidates=5,
                   warp_work_weight_m_per_J=3e-4, style_model=None, style=None,
                   style_strength=1.0):
        """Synthesises the target motion of one query, as mocap-synth does.

        A list of queries is synthesize_batch's (the same keywords but
        picks; a list in order of Synthesis or mocap.InputError).

        `results`: the search's answer for this query (a dict from search(),
        a list of them, or a mocap-search JSONL file); without it the query
        is searched here with the default options. `picks`: (pair, rank)
        tuples or "PAIR:RANK" strings (1-based; default rank 1). The other
        keywords are mocap-synth's flags (--transition, --max-states,
        --cost-threshold, --step-feet, --fps, --refine..., --energy: "w",
        the work energy, or "g", the paper's: the energy the A* search
        minimises; warp: None, the default, warps the pairs of a timed
        query; True, --warp (an untimed query is then an error); False,
        --no-warp; --warp-candidates: warp_candidates; --warp-work-weight:
        warp_work_weight_m_per_J; style_model, a dict
        from style_model() or a model file's path: --style-model, the
        report's "styles"; style, a style of that model: --style, the
        output turned toward it (docs/style.md "Style transfer");
        style_strength: --style-strength). Returns a Synthesis.
        """
        if isinstance(query, (list, tuple)):
            if picks:
                raise TypeError("picks name one query's results: give one query, "
                                "or synthesize_batch without picks")
            return self.synthesize_batch(
                query, results=results, threads=threads, base_dir=base_dir, method=method,
                max_states=max_states, cost_threshold_J=cost_threshold_J, step_feet=step_feet,
                fps=fps, refine=refine, refine_smoothing_J=refine_smoothing_J,
                refine_polish=refine_polish, refine_polish_window=refine_polish_window,
                refine_polish_segments=refine_polish_segments,
                refine_polish_smoothing_J=refine_polish_smoothing_J, energy=energy, warp=warp,
                warp_candidates=warp_candidates,
                warp_work_weight_m_per_J=warp_work_weight_m_per_J, style_model=style_model,
                style=style, style_strength=style_strength)
        text = _query_text(query)
        pick_texts = [p if isinstance(p, str) else f"{int(p[0])}:{int(p[1])}" for p in picks]
        args = dict(method=method, picks=pick_texts, max_states=max_states,
                    cost_threshold_J=cost_threshold_J, step_feet=step_feet, fps=fps,
                    refine=refine, refine_smoothing_J=refine_smoothing_J,
                    refine_polish=refine_polish, refine_polish_window=refine_polish_window,
                    refine_polish_segments=refine_polish_segments,
                    refine_polish_smoothing_J=refine_polish_smoothing_J, threads=threads,
                    energy=energy, warp=warp, warp_candidates=warp_candidates,
                    warp_work_weight_m_per_J=warp_work_weight_m_per_J,
                    style_model=_style_model_text(style_model), style=style or "",
                    style_strength=style_strength)
        return Synthesis(_with_results_file(
            results, lambda path: self._raw.synthesize(text, _base_dir(base_dir), results=path,
                                                       **args)))

    def synthesize_batch(self, queries, *, results=None, threads=0, base_dir=None,
                         method="astar", max_states=60, cost_threshold_J=5.0, step_feet=False,
                         fps=None, refine=0, refine_smoothing_J=0.0, refine_polish=0,
                         refine_polish_window=1, refine_polish_segments=False,
                         refine_polish_smoothing_J=0.0, energy="w", warp=None,
                         warp_candidates=5, warp_work_weight_m_per_J=3e-4, style_model=None,
                         style=None, style_strength=1.0):
        """Synthesises a batch of queries, as mocap-synth --queries does.

        `queries`: a list of queries (dicts or JSON texts). They are searched
        together (or their lines read from `results`: dicts from search(), or
        a mocap-search JSONL file) and synthesised in parallel (threads=0: all
        cores; the motions do not depend on it). Returns a list in input
        order: per query a Synthesis, equal to synthesize() of that query
        with the same keywords, or, for a query that failed, its
        mocap.InputError (returned, not raised). The keywords are
        synthesize()'s but picks (a batch has none).
        """
        if isinstance(queries, (dict, str)):
            raise TypeError("synthesize_batch takes a list of queries (synthesize: one query)")
        texts = [_query_text(q) for q in queries]
        args = dict(method=method, max_states=max_states, cost_threshold_J=cost_threshold_J,
                    step_feet=step_feet, fps=fps, refine=refine,
                    refine_smoothing_J=refine_smoothing_J, refine_polish=refine_polish,
                    refine_polish_window=refine_polish_window,
                    refine_polish_segments=refine_polish_segments,
                    refine_polish_smoothing_J=refine_polish_smoothing_J, threads=threads,
                    energy=energy, warp=warp, warp_candidates=warp_candidates,
                    warp_work_weight_m_per_J=warp_work_weight_m_per_J,
                    style_model=_style_model_text(style_model), style=style or "",
                    style_strength=style_strength)
        items = _with_results_file(
            results, lambda path: self._raw.synthesize_batch(texts, _base_dir(base_dir),
                                                             results=path, **args))
        return [_input_error(i) if isinstance(i, dict) else Synthesis(i) for i in items]

    def __repr__(self):
        return (f"<mocap.Index {self.path}: {len(self.clips)} clips, "
                f"{len(self.skeletons)} skeletons, {self.frame_count} frames>")


def recognise_style(model, file, *, frames=None, content=None):
    """The style of a BVH file, or of frames (S, E) of it (0-based,
    inclusive), by a style model (a dict from Index.style_model, or the path
    of a model file of mocap-index style-model): mocap-search style --json's
    object {"file", "frames", "style", "probabilities", "content",
    "content_recognised"} (docs/style.md). `content` names the motion's
    content; otherwise it is recognised."""
    if isinstance(model, (str, os.PathLike)):
        with open(model, encoding="utf-8") as f:
            model = json.load(f)
    span = None if frames is None else (int(frames[0]), int(frames[1]))
    return json.loads(_mocap.recognise_style(json.dumps(model), os.fspath(file), span,
                                             content or ""))


class Synthesis:
    """A synthesised motion (Index.synthesize).

    root_positions (F, 3) and joint_positions (F, J, 3) world, metres;
    local_rotations and world_rotations (F, J, 4) (w, x, y, z); joint_names,
    parents; frame_time_s, fps, times; segments (the query frames, partial
    motions and transitions it is made of), chosen (the partial motion used
    per pair), step_energies_J ((F - 1,) g of each step); report() the
    REPORT.json dict, bvh() the BVH text, write_bvh(path), write(path) by
    extension (.bvh, .glb, .npz), to_bvh() a Bvh.
    """

    def __init__(self, raw):
        self._raw = raw

    def __getattr__(self, name):
        if name == "_raw":  # not set yet (copy, pickle): no recursion
            raise AttributeError(name)
        return getattr(self._raw, name)

    @property
    def fps(self):
        return 1.0 / self._raw.frame_time_s

    @property
    def times(self):
        return np.arange(self._raw.frame_count) * self._raw.frame_time_s

    def report(self, query_file="", bvh_path=""):
        """mocap-synth's REPORT.json as a dict (query.file and motion.bvh as given)."""
        return json.loads(self._raw.report_json(query_file, os.fspath(bvh_path)))

    def report_html(self):
        """mocap-synth's REPORT.html text."""
        return self._raw.report_html()

    def write_bvh(self, path):
        """Writes the motion as BVH, as mocap-synth --out does."""
        self._raw.write_bvh(os.fspath(path))

    def write(self, path):
        """Writes the motion in the format its extension names, as
        mocap-synth --out does (docs/cli.md "Motion formats"): .glb (glTF
        binary: Blender, three.js, Unity, Godot), .npz (NumPy arrays:
        positions, rotations, translations, names, parents, fps), any other
        BVH. An existing file at `path` is replaced."""
        self._raw.write_motion(os.fspath(path))

    def bvh(self):
        """The motion's BVH text (the file write_bvh writes)."""
        with tempfile.TemporaryDirectory(prefix="mocap-") as tmp:
            path = os.path.join(tmp, "motion.bvh")
            self._raw.write_bvh(path)
            with open(path, encoding="utf-8") as f:
                return f.read()

    def to_bvh(self):
        """The motion as a Bvh (file units of its skeleton)."""
        return parse_bvh(self.bvh(), source="<synthesis>")

    def __repr__(self):
        return (f"<mocap.Synthesis {self._raw.query_id!r}: {self._raw.frame_count} frames at "
                f"{self.fps:g} fps, {len(self._raw.segments)} segments>")


class Bvh:
    """A BVH clip as the file has it: joint_names, parents ((J,) int32),
    offsets ((J, 3) file units), end_sites ((J, 3), NaN rows for joints
    without one), channels (per joint, file order), values ((F, C) channel
    values, file units and degrees, read-only), frame_time_s, fps,
    frame_count. motion() runs forward kinematics in metres.
    """

    def __init__(self, raw):
        self._raw = raw

    def __getattr__(self, name):
        if name == "_raw":  # not set yet (copy, pickle): no recursion
            raise AttributeError(name)
        return getattr(self._raw, name)

    @property
    def fps(self):
        return 1.0 / self._raw.frame_time_s

    @property
    def joint_count(self):
        return len(self._raw.joint_names)

    def motion(self, unit="auto"):
        """Forward kinematics in metres with `unit` (m, dm, cm, mm, inch,
        cmu, or auto: detected from the skeleton's height): a dict of
        joint_positions_m and local_translations_m (F, J, 3), world_rotations
        and local_rotations (F, J, 4) (w, x, y, z), unit, unit_scale_m."""
        return self._raw.motion(unit)

    def joint_positions(self, unit="auto"):
        """(F, J, 3) world joint origins in metres (motion())."""
        return self.motion(unit)["joint_positions_m"]

    def local_rotations(self):
        """(F, J, 4) local joint rotations (w, x, y, z)."""
        return self.motion("m")["local_rotations"]

    def text(self, precision=9):
        return self._raw.text(precision)

    def write(self, path, precision=9):
        self._raw.write(os.fspath(path), precision)

    def export_layout(self, tolerance=1e-4):
        """The clip with position channels on the root only (what Blender
        and three.js load alike; from_rotations writes this layout)."""
        return Bvh(self._raw.export_layout(tolerance))

    @classmethod
    def from_channels(cls, joint_names, parents, offsets, channels, values, frame_time_s,
                      end_sites=None, source="<arrays>"):
        """A clip from its channels: per joint a list of channel names
        ("Xposition", ..., "Zrotation") and (F, C) values in that order."""
        return cls(_mocap.Bvh.from_channels(list(joint_names), [int(p) for p in parents],
                                            offsets, [list(c) for c in channels], values,
                                            float(frame_time_s), end_sites, source))

    @classmethod
    def from_rotations(cls, joint_names, parents, offsets, rotations, root_positions,
                       frame_time_s, order="ZXY", end_sites=None, source="<arrays>"):
        """A clip from local rotations ((F, J, 4), w x y z) and root
        positions ((F, 3), or (F, R, 3) for R roots), in file units: roots
        get Xposition Yposition Zposition and the rotations in `order`, the
        other joints the rotations alone; offsets (J, 3) and end_sites (J, 3)
        (NaN rows: none) as written."""
        return cls(_mocap.Bvh.from_rotations(list(joint_names), [int(p) for p in parents],
                                             offsets, rotations, root_positions,
                                             float(frame_time_s), order, end_sites, source))

    def __repr__(self):
        return (f"<mocap.Bvh {self._raw.source}: {self.joint_count} joints, "
                f"{self._raw.frame_count} frames at {self.fps:g} fps>")


def read_bvh(path):
    """Reads a BVH file (any of the variations docs/cli.md lists)."""
    return Bvh(_mocap.read_bvh(os.fspath(path)))


def parse_bvh(text, source="<text>"):
    """Parses BVH text; `source` names it in error messages."""
    return Bvh(_mocap.parse_bvh(text, source))


def write_bvh(path, joint_names, parents, offsets, rotations, root_positions, frame_time_s,
              order="ZXY", end_sites=None, precision=9):
    """Writes a BVH file from arrays (Bvh.from_rotations) and returns the Bvh."""
    bvh = Bvh.from_rotations(joint_names, parents, offsets, rotations, root_positions,
                             frame_time_s, order=order, end_sites=end_sites,
                             source=os.fspath(path))
    bvh.write(path, precision)
    return bvh
