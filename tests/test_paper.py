"""The paper's experiments: empty lobes are silent, Table 1's grid and report, the figures."""

from __future__ import annotations

import json

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from _isolated import call_in_child

import batecho
from batecho.echoes.canonical import canonical_leaf_box
from batecho.paper import (
    PAPER_TABLE1,
    Table1Result,
    draw_tree_positions,
    machine_info,
    make_forest,
    paper_figures,
    table1,
)
from batecho.paper.settings import PAPER_CLEARANCE_M

# ---------------------------------------------------------------- empty and full lobes


@pytest.fixture(scope="module")
def box_scene():
    return batecho.Scene(canonical_leaf_box(np.random.default_rng(3), density_per_m3=10.0))


def test_empty_lobe_gives_an_exactly_zero_echo_leaf_box(box_scene):
    sonar = batecho.Sonar(beamwidth_deg=10)
    pose = batecho.Poses([5.5, 0.0, 5.0], [0.0, 1.0, 0.0])  # above the box, looking sideways
    assert len(batecho.lobe_members(box_scene, sonar, pose)) == 0
    e = batecho.simulate(box_scene, sonar, pose)
    assert e.n_leaves[0] == 0 and np.all(e.impulse == 0.0) and np.all(e.spectrum == 0.0)


def test_pose_facing_the_leaves_gives_a_nonzero_echo_leaf_box(box_scene):
    sonar = batecho.Sonar(beamwidth_deg=10)
    pose = batecho.Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    e = batecho.simulate(box_scene, sonar, pose)
    assert e.n_leaves[0] > 0 and np.any(e.impulse != 0.0)


@pytest.fixture(scope="module")
def one_tree():
    forest = make_forest([[0.0, 0.0]], np.random.default_rng(11))
    return forest, batecho.Scene(forest.leaves)


def test_empty_lobe_gives_an_exactly_zero_echo_tree(one_tree):
    _, scene = one_tree
    sonar = batecho.Sonar(beamwidth_deg=10)
    # On the paper's circle, looking along the path (tangent): past the crown.
    poses = batecho.circle((0.0, 0.0), 6.2, 5.0, n_points=24, heading="velocity")
    e = batecho.simulate(scene, sonar, poses)
    silent = e.n_leaves == 0
    assert silent.any()
    assert np.all(e.impulse[silent] == 0.0)


def test_pose_facing_the_crown_gives_a_nonzero_echo_tree(one_tree):
    forest, scene = one_tree
    crown = forest.leaves.centers.mean(axis=0)
    pose = batecho.look_at([6.2, 0.0, 5.0], crown)
    sonar = batecho.Sonar(beamwidth_deg=20, too_close="skip")
    e = batecho.simulate(scene, sonar, pose)
    members = batecho.lobe_members(scene, sonar, pose)
    assert e.n_leaves[0] == len(members) > 0 and np.any(e.impulse[0] != 0.0)


# --------------------------------------------------------------------- tree positions


def test_draw_tree_positions_gives_exactly_n_trees_in_the_window():
    pos = draw_tree_positions(4, np.random.default_rng(1))
    assert pos.shape == (4, 2)
    assert np.all((pos >= 0.0) & (pos <= 20.0))


def test_draw_tree_positions_is_reproducible():
    a = draw_tree_positions(3, np.random.default_rng(9))
    b = draw_tree_positions(3, np.random.default_rng(9))
    np.testing.assert_array_equal(a, b)


def test_draw_tree_positions_only_where_the_intensity_is_positive():
    lam = lambda x, y: np.where(x > 15.0, 0.05, 0.0)
    pos = draw_tree_positions(30, np.random.default_rng(2), intensity=lam)
    assert np.all(pos[:, 0] > 15.0)


def test_draw_tree_positions_rejects_zero_trees():
    with pytest.raises(ValueError, match="n_trees"):
        draw_tree_positions(0, np.random.default_rng(0))


# --------------------------------------------------------------------------- Table 1


def _fake_result() -> Table1Result:
    P, T, R = 2, 2, 1
    return Table1Result(
        points=(1, 15),
        trees=(1, 2),
        repeats=R,
        times_s=np.full((P, T, R), 0.01234),
        build_times_s=np.full((T, R), 0.001),
        grow_times_s=np.full((T, R), 0.2),
        n_leaves_scene=np.full((T, R), 20000),
        n_leaves_lobe=np.full((P, T, R), 3000),
        settings={"seed": 5, "sonar": {"beamwidth_deg": 50.0}, "heading": "center"},
    )


def test_table1_refuses_a_circle_too_large_for_memory_naming_points():
    got = call_in_child("table1(points=[10**8], trees=[1], repeats=1, timing_runs=1)",
                        setup="from batecho.paper import table1")  # fmt: skip
    assert got["raised"] == "MemoryError"
    assert "points = 100000000" in got["message"] and "memory limit" in got["message"]


def test_paper_figures_refuse_an_echo_image_too_large_for_memory_naming_echo_pulses(tmp_path):
    got = call_in_child(f"paper_figures({str(tmp_path)!r}, echo_pulses=10**9)",
                        setup="from batecho.paper import paper_figures")  # fmt: skip
    assert got["raised"] == "MemoryError"
    assert "echo_pulses = 1000000000" in got["message"] and "memory limit" in got["message"]


def test_table1_markdown_puts_the_papers_figures_beside_ours():
    md = _fake_result().to_markdown()
    for p in (1, 15):
        row = next(line for line in md.splitlines() if line.startswith(f"| {p} | 0.0123"))
        for t in (1, 2):
            assert f"({PAPER_TABLE1[p][t - 1]:.2f};" in row


def test_table1_markdown_states_how_to_rerun_it():
    md = _fake_result().to_markdown()
    assert "batecho paper table1 --points 1,15 --trees 1,2 --repeats 1 --seed 5" in md


def test_table1_npz_keeps_the_settings(tmp_path):
    path = _fake_result().to_npz(tmp_path / "t1.npz")
    with np.load(path) as z:
        assert json.loads(str(z["settings_json"]))["seed"] == 5
        assert z["paper_times_s"][1, 1] == PAPER_TABLE1[15][1]


def test_table1_npz_is_written_at_the_path_it_returns_without_an_npz_suffix(tmp_path):
    path = _fake_result().to_npz(tmp_path / "t1.data")
    assert path == tmp_path / "t1.data" and sorted(tmp_path.iterdir()) == [path]
    with np.load(path) as z:
        assert json.loads(str(z["settings_json"]))["seed"] == 5


@pytest.fixture(scope="module")
def small_table():
    return table1(points=(1, 5), trees=(1, 2), seed=3, repeats=1, timing_runs=1)


def test_table1_has_the_requested_grid(small_table):
    r = small_table
    assert r.points == (1, 5) and r.trees == (1, 2)
    assert r.times_s.shape == (2, 2, 1) and r.n_leaves_lobe.shape == (2, 2, 1)
    assert r.n_leaves_scene.shape == (2, 1) and r.build_times_s.shape == (2, 1)


def test_table1_times_and_leaf_counts_are_positive(small_table):
    r = small_table
    assert np.all(r.times_s > 0) and np.all(r.build_times_s > 0)
    assert np.all(r.n_leaves_scene > 0) and np.all(r.n_leaves_lobe > 0)


def test_table1_forest_depends_on_seed_and_tree_count_only():
    a = table1(points=(1,), trees=(2,), seed=3, repeats=1, timing_runs=1)
    b = table1(points=(5, 1), trees=(1, 2), seed=3, repeats=1, timing_runs=1)
    assert a.n_leaves_scene[0, 0] == b.n_leaves_scene[1, 0]
    assert a.n_leaves_lobe[0, 0, 0] == b.n_leaves_lobe[1, 1, 0]


def test_table1_records_the_machine_and_the_tree_model(small_table):
    s = small_table.settings
    assert s["machine"]["cpu_count"] >= 1 and s["tree"]["function"].startswith("batecho.trees.")


def test_machine_info_names_the_cpu_family_model_and_vector_instructions():
    m = machine_info()
    assert m["vector_isa"] in ("AVX-512", "AVX2", None)
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            text = fh.read()
    except OSError:
        pytest.skip("no /proc/cpuinfo")
    fields = dict(
        (k.strip(), v.strip())
        for k, _, v in (line.partition(":") for line in text.split("\n\n")[0].splitlines())
    )
    if "cpu family" in fields:
        assert m["cpu_family_model"] == f"{fields['cpu family']}/{fields['model']}"
    flags = fields.get("flags", "").split()
    assert (m["vector_isa"] == "AVX-512") == ("avx512f" in flags)


# --------------------------------------------------------------------------- figures


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory):
    """The figures of seed 4 written, and each Figure as it was drawn (before it closed)."""
    from batecho.paper import figures as module

    drawn: dict = {}
    save = module._savefig

    def keep(fig, path, dpi):
        fig.canvas.draw()
        drawn[path.stem] = _layout(fig)
        return save(fig, path, dpi)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(module, "_savefig", keep)
        written = paper_figures(tmp_path_factory.mktemp("paper"), seed=4, echo_pulses=12, dpi=50)
    return written, drawn


def _layout(fig) -> list[dict]:
    """Per 2-D panel: its x label, whether any x tick label shows, its y label, the y offset
    text, and the labels of the axes drawn on it (a secondary range axis)."""
    out = []
    for ax in fig.axes:
        if ax.name == "3d" or ax.get_label() == "<colorbar>" or not ax.get_ylabel():
            continue
        shown = [t for t in ax.get_xticklabels() if t.get_visible() and t.get_text()]
        out.append(
            {
                "xlabel": ax.get_xlabel(),
                "xticks_shown": bool(shown),
                "ylabel": ax.get_ylabel(),
                "offset": ax.yaxis.get_offset_text().get_text(),
                "on_top": [c.get_xlabel() for c in ax.child_axes],
            }
        )
    return out


def test_paper_figures_writes_decodable_pngs_and_data(paper_run):
    written, _ = paper_run
    pngs = [p for p in written.values() if p.suffix == ".png"]
    assert {"fig05", "fig06", "fig07", "fig08", "fig09", "fig10"} <= set(written)
    for p in pngs:
        assert p.stat().st_size > 0 and plt.imread(p).ndim == 3
    with np.load(written["data"]) as z:
        assert not np.any(z["fig05_impulse"])  # the empty lobe: exactly zero
        assert np.all(z["fig09_n_leaves"] >= 0) and z["fig09_impulses"].shape[0] == 4


def test_paper_figures_report_each_paths_smallest_clearance(paper_run):
    written, _ = paper_run
    with np.load(written["data"]) as z:
        settings = json.loads(str(z["settings_json"]))
        run = z["straight_run_positions"]
    got = settings["min_clearance_m"]
    assert set(got) == {
        "one_tree_circle",
        "two_trees_circle",
        "fig10_2_trees_circle",
        "fig10_3_trees_circle",
        "straight_run",
    }
    # every path keeps the paper's margin, and the run ends that far outside the crown
    assert all(d >= PAPER_CLEARANCE_M - 1e-9 for d in got.values())
    assert got["straight_run"] == pytest.approx(PAPER_CLEARANCE_M, abs=0.05)
    assert len(run) == 24


def test_paper_panels_with_hidden_ticks_carry_no_axis_label(paper_run):
    _, drawn = paper_run
    for name, panels in drawn.items():
        for p in panels:
            assert p["xticks_shown"] or not p["xlabel"], (name, p)


def test_paper_figures_name_the_range_axis_once_per_stack(paper_run):
    _, drawn = paper_run
    tops = [p["on_top"] for p in drawn["fig07_impulse_beamwidths"]]
    assert tops == [["range (m)"], [], []]


def test_paper_impulse_axes_have_units_and_no_offset_text(paper_run):
    _, drawn = paper_run
    for name in ("fig07_impulse_beamwidths", "fig09_impulses_circle", "straight_run_impulses"):
        for p in drawn[name]:
            assert p["ylabel"].startswith("echo, relative pressure") and p["offset"] == "", name


def test_paper_experiments_keep_every_pulse_half_a_metre_from_leaves_and_bark(paper_run):
    written, _ = paper_run
    ss = np.random.SeedSequence(4)
    rngs = [np.random.default_rng(s) for s in ss.spawn(3)]
    one = make_forest(np.zeros((1, 2)), rngs[0], "grow_tree")
    pos2 = draw_tree_positions(2, rngs[1])
    two = make_forest(pos2, rngs[1], "grow_tree")
    with np.load(written["data"]) as z:
        np.testing.assert_array_equal(z["two_trees_positions"], pos2)
        assert one.clearance(z["straight_run_positions"]).min() >= 0.5
        assert one.clearance(z["fig06_position"][None]).min() >= 0.5
        assert two.clearance(z["fig09_positions"]).min() >= 0.5
        assert two.clearance(z["echo_image_positions"]).min() >= 0.5


def test_table1_circles_keep_half_a_metre_from_every_crown(small_table):
    radii = small_table.settings["radii_m"]
    assert set(radii) == {"T=1, forest 0", "T=2, forest 0"}
    for t in (1, 2):
        rng = np.random.default_rng([3, t, 0])
        pos = draw_tree_positions(t, rng)
        forest = make_forest(pos, rng, "grow_tree")
        r = radii[f"T={t}, forest 0"]
        assert r >= 6.2
        ring = batecho.circle(pos.mean(axis=0), r, 5.0, n_points=360)
        assert forest.clearance(ring.positions).min() >= 0.5
