"""The figures README.md and the docs quote are those ``experiments/doc_figures.py`` measured.

``experiments/results/doc_figures.json`` holds what the script measured; each document must
quote it, so a rerun of the script that changes a figure fails here until the documents
follow.  The slow test trains the default run again and gets the same returns.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
FIGURES = json.loads((ROOT / "experiments" / "results" / "doc_figures.json").read_text())
README = (ROOT / "README.md").read_text()
QUICKSTART = (ROOT / "docs" / "quickstart.md").read_text()
CLI = (ROOT / "docs" / "cli.md").read_text()


def _last_eval() -> str:
    last = FIGURES["train"]["evaluations"][-1]
    return f"{last['mean']:.2f} ± {last['std']:.2f}"


def test_the_quickstart_transcript_is_the_measured_one():
    runs = re.compile(r"/\S*runs/quadx_hover/ppo/\d{8}-\d{6}-seed0")
    quoted = [runs.sub("<run>", line) for line in QUICKSTART.splitlines()]
    for line in FIGURES["train"]["transcript"]:
        assert runs.sub("<run>", line) in quoted, f"docs/quickstart.md does not quote: {line}"
    t = FIGURES["train"]
    assert f"{t['training_s']:.0f} s of training, {t['wall_s']:.0f} s for the whole command" in QUICKSTART
    e = FIGURES["eval"]
    assert (
        f"returns {e['mean_return']:.2f} ± {e['std_return']:.2f} and holds {100 * e['mean_distance_m']:.1f} cm"
        in QUICKSTART
    )


def test_the_readme_quotes_the_default_run_and_its_video_frame():
    assert f"last evaluation returns {_last_eval().replace('-', '-')}" in README.replace("\n", " ")
    t, v = FIGURES["train"], FIGURES["video"]
    assert f"Training took {t['training_s']:.0f} s ({t['wall_s']:.0f} s for the whole command" in README.replace(
        "\n", " "
    )
    assert f"{100 * v['distance_m']:.1f} cm from it, return {v['return']:.2f} after 5 s" in README.replace("\n", " ")
    assert v["frame"] == 150 and (ROOT / v["image"]).is_file()


def test_the_cli_eval_example_is_the_default_run_flown():
    for i, ret in enumerate(FIGURES["eval"]["returns"][:5]):
        assert re.search(rf"^\s+{i}\s+{1000 + i}\s+{ret:.2f}\s+300\s+yes\s+time limit\s", CLI, re.M), (i, ret)
    for i, distance in enumerate(FIGURES["eval"]["distance_m"][:5]):  # the task's distance-held column
        assert re.search(rf"^\s+{i}\s+{1000 + i}\s.*time limit\s+{distance:.3f}\s", CLI, re.M), (i, distance)
    assert f"return        {_last_eval()}  (mean ± std over 5 episodes)" in CLI


def test_eval_reports_the_distance_held_that_doc_figures_computed_by_hand(tmp_path, monkeypatch):
    """``experiments/doc_figures.py`` measures the distance from the recorded positions itself;
    the hover task's own measure, flown by ``pyflyt eval`` of the same policy, is the same."""
    from pyflyt_cli.training import evaluate_run
    from pyflyt_cli.zoo import materialise

    monkeypatch.chdir(tmp_path)
    report = evaluate_run(materialise("quadx_hover_ppo"), {"episodes": 3, "record": False})
    by_hand = FIGURES["eval"]["distance_m"][:3]
    assert [e.measures["distance_mean"] for e in report.episodes] == pytest.approx(by_hand, rel=1e-9)


@pytest.mark.long
def test_the_readme_frame_is_what_its_caption_says_the_command_films(tmp_path, monkeypatch):
    """The caption names `pyflyt replay <run>/episodes/ep_0000.mcap --video hover.mp4 --size WxH`
    and a frame: filmed again from the same policy's first evaluation episode (the shipped
    hover agent is the default run, above), that frame at that size is the committed image,
    up to the MP4 encoding it went through."""
    import itertools

    import numpy as np
    from PIL import Image

    from pyflyt_cli.training import evaluate_run
    from pyflyt_cli.zoo import materialise
    from pyflyt_engine.telemetry import load_episode
    from pyflyt_engine.telemetry.video import episode_frames

    caption = re.search(r"\(Frame (\d+) of `pyflyt replay \S+ --video \S+ --size (\d+)x(\d+)`", README)
    assert caption, "the README's video caption names its frame and size"
    frame, width, height = (int(g) for g in caption.groups())
    assert frame == FIGURES["video"]["frame"]
    image = Image.open(ROOT / FIGURES["video"]["image"]).convert("RGB")
    assert image.size == (width, height)
    monkeypatch.chdir(tmp_path)
    report = evaluate_run(materialise("quadx_hover_ppo"), {"episodes": 1, "record": True})
    frames = episode_frames(load_episode(report.recordings[0]), (width, height))
    early, filmed = (np.asarray(f)[..., :3].astype(float) for f in itertools.islice(frames, frame - 30, frame + 1, 30))
    committed = np.asarray(image).astype(float)
    assert np.abs(filmed - committed).mean() < 3.0  # the encoding's loss only
    assert np.abs(early - committed).mean() > np.abs(filmed - committed).mean()  # another frame is further off


def test_the_shipped_hover_agent_is_the_default_run():
    """Trained in another process by the same command, the zoo agent is the same policy."""
    summary = yaml.safe_load((ROOT / "pyflyt_cli/zoo/agents/quadx_hover_ppo/summary.yaml").read_text())
    assert [round(r, 2) for r in summary["evaluation"]["returns"]] == FIGURES["eval"]["returns"]


def test_the_zoo_lines_say_every_agent_matches():
    for name, result in FIGURES["zoo"].items():
        assert result["line"].endswith("(matches episode by episode)"), name


@pytest.mark.slow  # the default training run (~2 minutes on 2 cores)
def test_the_default_run_trains_to_the_documented_returns(tmp_path):
    from tests.train.conftest import pyflyt

    done = pyflyt(["train"], tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    evals = re.findall(r"eval return (-?[\d.]+) ± ([\d.]+)", done.stderr + done.stdout)
    assert [(float(m), float(s)) for m, s in evals] == [(e["mean"], e["std"]) for e in FIGURES["train"]["evaluations"]]
