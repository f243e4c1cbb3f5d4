"""The CLI's error contract: every mistake a user can make ends as one line on stderr, exit 2.

:data:`CASES` is the one list of such mistakes: add a case as one line, ``(id, command line,
expected part of the message)``. The command line is split like a shell would and these
placeholders are filled in:

``{rec}``   a copy of ``recordings/exp1.mcap`` (an input: it must come out unchanged)
``{tmp}``   a fresh empty directory (the test checks that nothing is left behind in it)
``{ro}``    a read-only directory inside ``{tmp}``
``{bad}``   a file of garbage bytes, ``{tmp}/bad.json``
``{docs}``  the repository's ``docs/`` (a folder without recordings)
``{templates}``  the shipped template recordings ``recordings/templates``
``{binary}``, ``{badjson}``, ``{inverted}``  template files: binary, JSON cut short, and the
            shipped templates with the range of column 0 inverted
``{photo}``, ``{depth}``, ``{k}``, ``{truncated}``, ``{pixel}``  a colour PNG, a depth PNG,
            intrinsics, a PNG cut in half and a 1x1 PNG (:func:`_still_inputs`)
``{overlap}``, ``{pastend}``, ...  label files for ``{rec}`` with one mistake each (:func:`bad_labels`)

Every case runs :func:`lfd.cli.main` in this process (the default run) and, marked ``slow``,
``python -m lfd.cli`` in a subprocess, as a user would; either must exit with status 2, print
exactly one non-empty line on stderr, starting with ``lfd `` and without a traceback, modify no
input and leave no output (nor temporary) file. Keep cases fast: fail before the heavy work.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shlex
import stat
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import _paths
import pytest

ROOT = _paths.ROOT
EXP1 = ROOT / "recordings" / "exp1.mcap"

# fmt: off
CASES: list[tuple[str, str, str]] = [
    # info
    ("info-missing", "info {tmp}/nope.mcap", "nope.mcap"),
    ("info-json-is-input", "info {rec} --json {rec}", "also an input"),
    ("info-json-missing-dir", "info {rec} --json {tmp}/no/such/dir/x.json", "does not exist"),
    # simulate
    ("simulate-task-and-set", "simulate exp1 --set eval -o {tmp}/set", "drop exp1"),
    ("simulate-no-task", "simulate -o {tmp}/x.mcap", "give a TASK"),
    ("simulate-set-into-file", "simulate --set eval -o {rec}", "is a file"),
    ("simulate-output-missing-dir", "simulate exp1 -o {tmp}/no/x.mcap", "does not exist"),
    ("simulate-output-extension", "simulate exp1 -o {tmp}/x.json", "extension"),
    ("simulate-unknown-task", "simulate exp9 -o {tmp}/x.mcap", "invalid choice"),
    # segment
    ("segment-json-is-input", "segment {rec} --json {rec}", "also an input"),
    ("segment-rrd-is-input", "segment {rec} --rerun-save {rec}", "also an input"),
    ("segment-rrd-extension", "segment {rec} --rerun-save {tmp}/x.mcap", "extension"),
    ("segment-json-missing-dir", "segment {rec} --json {tmp}/no/x.json", "does not exist"),
    ("segment-json-is-dir", "segment {rec} --json {tmp}", "is a directory"),
    ("segment-json-read-only-dir", "segment {rec} --json {ro}/x.json", "not writable"),
    ("segment-missing-input", "segment {tmp}/nope.mcap", "nope.mcap"),
    ("segment-input-is-dir", "segment {docs}", "no .mcap recordings in"),
    ("segment-rerun-connect", "segment {rec} --rerun-connect bogus://", "not a viewer URL"),
    ("segment-rerun-connect-http", "segment {rec} --rerun-connect http://h:1/proxy", "rerun+http"),
    ("segment-rerun-bind", "segment {rec} --rerun-serve --rerun-bind localhost", "not an IP"),
    ("segment-rerun-serve-for", "segment {rec} --rerun-serve-for -1", "seconds >= 0"),
    ("segment-unknown-option", "segment {rec} --bogus", "unrecognized arguments"),
    ("segment-bad-choice", "segment {rec} --search nope", "invalid choice"),
    ("segment-paper-and-dp", "segment {rec} --paper --search dp", "--paper"),
    ("segment-json-to-stdout-twice", "segment {rec} --json", "expected one argument"),
    # many recordings (docs/batch.md)
    ("segment-batch-jobs-0", "segment {rec} {rec} --jobs 0", "argument --jobs: must be an integer >= 1, got '0'"),
    ("segment-batch-follow", "segment {rec} {rec} --follow", "--follow follows one recording"),
    ("segment-batch-rerun", "segment {rec} {rec} --rerun-save {tmp}/x.rrd", "--rerun* shows one recording"),
    ("segment-batch-ray-took-input", "segment --ray {rec} {rec}", "put --ray after the recordings"),
    ("eval-jobs-not-number", "eval {rec} --jobs many", "argument --jobs: must be an integer"),
    ("eval-loo-ray", "eval {rec} {rec} --leave-one-out --ray", "drop it with --leave-one-out"),
    ("templates-train-jobs-0", "templates train {rec} -o {tmp}/t.json --jobs 0", "argument --jobs"),
    # templates
    ("templates-train-no-recordings", "templates train {docs} -o {tmp}/t.json", "no .mcap"),
    ("templates-train-output-is-input", "templates train {rec} -o {rec}", "also an input"),
    ("templates-train-output-missing-dir", "templates train {rec} -o {tmp}/no/t.json", "not exist"),
    ("templates-show-missing", "templates show {tmp}/nope.json", "nope.json"),
    ("templates-no-action", "templates", "required"),
    ("templates-train-base-missing", "templates train {rec} --base {tmp}/no.json -o {tmp}/t.json", "no.json"),
    ("templates-train-base-and-params", "templates train {rec} --base default --params '{}' -o {tmp}/t.json", "--base keeps"),
    ("templates-train-base-is-output", "templates train {rec} --base {tmp}/t.json -o {tmp}/t.json", "t.json"),
    ("templates-train-confidence-above-1", "templates train {rec} --min-keypoint-confidence 1.5 -o {tmp}/t.json", "--min-keypoint-confidence must be in [0, 1], got 1.5"),
    ("templates-train-confidence-negative", "templates train {rec} --min-keypoint-confidence=-0.1 -o {tmp}/t.json", "--min-keypoint-confidence must be in [0, 1], got -0.1"),
    ("templates-train-confidence-nan", "templates train {rec} --min-keypoint-confidence nan -o {tmp}/t.json", "got nan"),
    ("templates-train-confidence-not-number", "templates train {rec} --min-keypoint-confidence high -o {tmp}/t.json", "invalid float value"),
    ("templates-train-base-and-confidence", "templates train {rec} --base default --min-keypoint-confidence 0.3 -o {tmp}/t.json", "--base keeps its own"),
    # label: bad labels leave the recording byte-identical
    ("label-overlap", "label {rec} --from {overlap}", "labels overlap"),
    ("label-past-end", "label {rec} --from {pastend}", "ends after the recording"),
    ("label-negative", "label {rec} --from {negative}", "starts before the recording"),
    ("label-inverted", "label {rec} --from {inverted_labels}", "ends before it starts"),
    ("label-unknown-skill", "label {rec} --from {unknownskill}", "unknown skill 'grab'"),
    ("label-unknown-object", "label {rec} --from {unknownobject}", "unknown object 'box_9'"),
    ("label-not-a-number", "label {rec} --from {nan_labels}", "finite number"),
    ("label-bad-json", "label {rec} --from {badjson}", "not valid JSON"),
    ("label-binary", "label {rec} --from {bad}", "not a label file"),
    ("label-missing", "label {rec} --from {tmp}/nope.csv", "--from"),
    ("label-no-from", "label {rec}", "--from"),
    ("label-output-extension", "label {rec} --from {overlap} -o {tmp}/x.json", "extension"),
    ("label-output-missing-dir", "label {rec} --from {overlap} -o {tmp}/no/x.mcap", "not exist"),
    ("label-not-a-recording", "label {bad} --from {overlap}", "not an MCAP file"),
    # eval
    ("eval-bogus-method", "eval {rec} --methods bogus", "unknown method"),
    ("eval-no-recordings", "eval {docs}", "no .mcap"),
    ("eval-json-is-input", "eval {rec} --json {rec}", "also an input"),
    ("eval-json-is-dir", "eval {rec} --json {tmp}", "is a directory"),
    ("eval-base-without-loo", "eval {rec} --base default", "add --leave-one-out"),
    ("eval-loo-one-recording", "eval {rec} --leave-one-out", "at least 2 recordings"),
    ("eval-loo-baselines-only", "eval {rec} --leave-one-out --methods proximity", "needs one of"),
    ("eval-loo-base-missing", "eval {rec} --leave-one-out --base {tmp}/no.json", "no.json"),
    # reproduce
    ("reproduce-json-is-input", "reproduce {rec} --json {rec}", "also an input"),
    ("reproduce-json-missing-dir", "reproduce {rec} --json {tmp}/no/x.json", "does not exist"),
    ("reproduce-rrd-is-input", "reproduce {rec} --rerun-save {rec}", "also an input"),
    ("reproduce-bad-mode", "reproduce {rec} --mode fly", "invalid choice"),
    ("reproduce-unknown-robot", "reproduce {rec} --robot ur5 --json {tmp}/r.json", "unknown robot 'ur5'; known robots: kuka_lwr4, panda"),
    ("reproduce-displace-cm", "reproduce {rec} --displace box_2:8,-5", "did you mean box_2:0.08,-0.05"),
    ("reproduce-displace-nan", "reproduce {rec} --displace box_2:nan,0", "finite"),
    ("reproduce-displace-unknown", "reproduce {rec} --displace box_9:0.05,0", "known objects"),
    ("reproduce-displace-1e308", "reproduce {rec} --displace box_2:1e308,0", "--displace box_2:1e+308,0 moves box_2 by 1e+308 m (at most 1 m)"),
    ("reproduce-displace-turn-1e308", "reproduce {rec} --displace box_2:0.05,0,1e308", "a turn of 1e+308 degrees; give at most 360 either way"),
    ("reproduce-displace-twice", "reproduce {rec} --displace box_2:0.05,0 --displace box_2:0,0.05", "--displace box_2:... is given twice"),
    ("reproduce-displace-underscore", "reproduce {rec} --displace box_2:1_0,0", "expected NAME:DX,DY[,DEG]"),
    # record
    ("record-output-missing-dir", "record --source sim:exp1 -o {tmp}/no/x.mcap", "not exist"),
    ("record-output-is-dir", "record --source sim:exp1 -o {tmp}", "is a directory"),
    ("record-rerun-connect", "record --source sim:exp1 -o {tmp}/x.mcap --rerun-connect x", "URL"),
    ("record-no-source", "record -o {tmp}/x.mcap", "--source"),
    # perception
    ("perception-train-extension", "perception train -o {tmp}/m.json", "extension"),
    ("perception-train-missing-dir", "perception train -o {tmp}/no/m.pt", "does not exist"),
    ("perception-train-old-out", "perception train --out {tmp}/m.pt", "--output"),
    ("perception-eval-old-model", "perception eval --model {tmp}/m.pt", "unrecognized"),
    ("perception-eval-missing-model", "perception eval --hand-model {tmp}/nope.pt", "nope.pt"),
    ("record-missing-model", "record --source sim:exp1 -o {tmp}/x.mcap --hand-model {tmp}/n.pt", "n.pt"),
    ("record-bad-hand-model", "record --source sim:exp1 -o {tmp}/x.mcap --hand-model openpose", "expected mediapipe, depth-net"),
    ("record-bad-hand", "record --source sim:exp1 -o {tmp}/x.mcap --hand both", "invalid choice"),
    # export
    ("export-lerobot-not-empty", "export lerobot {rec} -o {tmp}", "is not empty; pass --overwrite"),
    ("export-lerobot-holds-input", "export lerobot {rec} -o {tmp} --overwrite", "holds the input"),
    ("export-no-format", "export {rec}", "invalid choice"),
    ("record-live-no-hand", "record --source sim:exp1 -o {tmp}/x.mcap --no-hand --live-segment", "needs the hand"),
    ("hands-unreadable-image", "perception hands {bad}", "bad.json: not a readable image"),
    ("hands-missing-image", "perception hands {tmp}/none.png", "none.png: image not found"),
    ("hands-truncated-png", "perception hands {truncated}", "cut.png: not a readable image"),
    ("hands-depth-no-intrinsics", "perception hands {photo} --depth {photo}", "need --intrinsics"),
    ("hands-depth-count", "perception hands {photo} {photo} --depth {depth} --intrinsics {k}", "2 colour images"),
    ("hands-depth-not-16bit", "perception hands {photo} --depth {photo} --intrinsics {k}", "16-bit"),
    ("hands-depth-wrong-size", "perception hands {photo} --depth {depth} --intrinsics {k}", "must be aligned"),
    ("hands-bad-intrinsics", "perception hands {photo} --depth {depth} --intrinsics {bad}", "bad.json is not UTF-8 text"),
    ("hands-json-is-input", "perception hands {photo} --json {photo}", "also an input"),
    ("hands-one-pixel", "perception hands {photo} {pixel} --json {tmp}/h.json", "pixel.png: the image is 1x1 pixels, too small to find a hand in (at least 2x2)"),
    # recordings from other tools: --object-size, ROS bags (--map, lfd import ros)
    ("segment-object-size-unknown", "segment {rec} --object-size box_9=0.1,0.1,0.1", "'box_9', which the recording does not have; its objects are box_1, box_2, box_3"),
    ("segment-object-size-nan", "segment {rec} --object-size box_1=nan,0.1,0.1", "argument --object-size: a size is three positive finite lengths"),
    ("segment-object-size-zero", "segment {rec} --object-size box_1=0.1,0,0.1", "positive finite"),
    ("segment-object-size-huge", "segment {rec} --object-size box_1=1e300,1,1", "each at most 2 m (an object a hand handles)"),
    ("reproduce-object-size-huge", "reproduce {rec} --mode skills --object-size box_2=0.05,0.05,1e3", "each at most 2 m"),
    ("segment-object-size-no-name", "segment {rec} --object-size 0.1,0.1,0.1", "expected NAME=X,Y,Z"),
    ("segment-object-size-underscore", "segment {rec} --object-size box_1=0.0_5,0.05,0.05", "expected NAME=X,Y,Z with three numbers"),
    ("segment-object-size-twice", "segment {rec} --object-size box_1=0.1,0.1,0.1 --object-size box_1=0.2,0.2,0.2", "given twice"),
    ("info-object-size-unknown", "info {rec} --object-size box_9=0.1,0.1,0.1", "its objects are box_1"),
    ("eval-object-size-unknown", "eval {rec} --object-size box_9=0.1,0.1,0.1", "its objects are box_1"),
    ("templates-train-object-size-unknown", "templates train {rec} -o {tmp}/t.json --object-size box_9=0.1,0.1,0.1", "its objects are box_1"),
    ("label-object-size-unknown", "label {rec} --from {overlap} --object-size box_9=0.1,0.1,0.1", "its objects are box_1"),
    ("reproduce-object-size-unknown", "reproduce {rec} --object-size box_9=0.1,0.1,0.1", "its objects are box_1"),
    ("segment-map-for-lfd-recording", "segment {rec} --map {bagmap}", "not a ROS bag: drop the topic mapping"),
    ("segment-bag-without-map", "segment {bag}", "is a ROS bag: give a topic mapping with --map"),
    ("info-bag-without-map", "info {bag}", "is a ROS bag: give a topic mapping with --map"),
    ("reproduce-bag-without-map", "reproduce {bag} --segment", "--map"),
    ("segment-map-missing-topic", "segment {bag} --map {map_missing}", "does not have: /hand/kp (hand); the bag has: /hand/keypoints (geometry_msgs/msg/PoseArray, 73 msgs), /tf"),
    ("segment-map-unknown-type", "segment {bag} --map {map_type}", "has message type tf2_msgs/msg/TFMessage, which lfd cannot read as hand keypoints; supported: geometry_msgs/PoseArray, visualization_msgs/MarkerArray"),
    ("segment-map-malformed", "segment {bag} --map {map_bad}", "hand.side must be"),
    ("segment-map-not-toml", "segment {bag} --map {bad}", "not a valid TOML topic mapping"),
    ("segment-map-missing", "segment {bag} --map {tmp}/no.toml", "--map"),
    ("segment-follow-map", "segment {rec} --follow --map {bagmap}", "drop --map"),
    ("import-no-map", "import ros {bag} -o {tmp}/x.mcap", "--map"),
    ("import-no-source", "import", "required"),
    ("import-map-missing-topic", "import ros {bag} --map {map_missing} -o {tmp}/x.mcap", "the bag has: /hand/keypoints"),
    ("import-map-unknown-key", "import ros {bag} --map {map_key} -o {tmp}/x.mcap", "unknown key 'hnad'"),
    ("import-output-extension", "import ros {bag} --map {bagmap} -o {tmp}/x.json", "extension"),
    ("import-output-is-dir", "import ros {bag} --map {bagmap} -o {tmp}", "is a directory"),
    ("import-missing-bag", "import ros {tmp}/no.bag --map {bagmap} -o {tmp}/x.mcap", "no.bag"),
    ("import-not-a-bag", "import ros {bad} --map {bagmap} -o {tmp}/x.mcap", "not an MCAP file"),
    # a failing command that had opened --rerun-save leaves no .rrd
    ("segment-failed-rrd", "segment {tmp}/no.mcap --rerun-save {tmp}/o.rrd", "no.mcap"),
    # values out of range, NaN / inf, bad --params and template files: refused before any work
    ('simulate-seed-1', "simulate exp1 -o {tmp}/out.mcap --seed -1", "argument --seed: must be an integer in [0, 2**63 - 1], got '-1'"),
    ('simulate-seed-1.5', "simulate exp1 -o {tmp}/out.mcap --seed 1.5", "argument --seed: must be an integer, got '1.5'"),
    ('simulate-seed-underscore', "simulate exp1 -o {tmp}/out.mcap --seed 1_0", "argument --seed: must be an integer, got '1_0'"),
    ('simulate-duration-underscore', "simulate exp1 -o {tmp}/out.mcap --duration 1_0", "argument --duration: must be a number, got '1_0'"),
    ('simulate-duration-1', "simulate exp1 -o {tmp}/out.mcap --duration -1", "argument --duration: must be a number > 0, got '-1'"),
    ('simulate-duration-0', "simulate exp1 -o {tmp}/out.mcap --duration 0", "argument --duration: must be a number > 0, got '0'"),
    ('simulate-duration-nan', "simulate exp1 -o {tmp}/out.mcap --duration nan", "argument --duration: must be a finite number, got 'nan'"),
    ('simulate-duration-1e10', "simulate locate -o {tmp}/out.mcap --duration 1e10", "argument --duration: must be at most 86400 s (24 h), got '1e10'"),
    ('simulate-duration-1e308', "simulate locate -o {tmp}/out.mcap --duration 1e308", "argument --duration: must be at most 86400 s (24 h)"),
    ('simulate-duration-9e9', "simulate exp1 -o {tmp}/out.mcap --duration 9e9", "argument --duration: must be at most 86400 s"),
    ('simulate-hand-rate-0', "simulate exp1 -o {tmp}/out.mcap --hand-rate 0", 'argument --hand-rate: must be a number in [0.5, 30]'),
    ('simulate-hand-rate-inf', "simulate exp1 -o {tmp}/out.mcap --hand-rate inf", 'argument --hand-rate: must be a finite number'),
    ('simulate-render-rate-0', "simulate exp1 -o {tmp}/out.mcap --render --render-rate 0", 'argument --render-rate: must be a number in (0'),
    ('simulate-render-rate-500', "simulate exp1 -o {tmp}/out.mcap --render-rate 500", 'argument --render-rate: must be a number in (0, 30]'),
    ('simulate-speed-0', "simulate exp1 -o {tmp}/out.mcap --speed 0", 'argument --speed: speed must be in [0.2, 5], got 0.0'),
    ('simulate-hand-scale-1', "simulate exp1 -o {tmp}/out.mcap --hand-scale -1", 'argument --hand-scale: variability hand_scale must be'),
    ('simulate-dropout-2', "simulate exp1 -o {tmp}/out.mcap --dropout 2", 'argument --dropout: dropout must be a probability <= 0.9'),
    ('simulate-pauses-nan', "simulate exp1 -o {tmp}/out.mcap --pauses nan", "argument --pauses: must be a finite number, got 'nan'"),
    ('simulate-noise-mm-3', "simulate exp1 -o {tmp}/out.mcap --noise-mm -3", 'argument --noise-mm: variability noise_mm must be'),
    ('simulate-tremor-mm-inf', "simulate exp1 -o {tmp}/out.mcap --tremor-mm inf", 'argument --tremor-mm: must be a finite number'),
    ('simulate-outliers-1', "simulate exp1 -o {tmp}/out.mcap --outliers 1", 'argument --outliers: outlier_rate must be a probability'),
    ('simulate-hand-miss-0.1', "simulate exp1 -o {tmp}/out.mcap --hand-miss -0.1", 'argument --hand-miss: variability hand_miss must be'),
    ('simulate-approach-deg-270', "simulate exp1 -o {tmp}/out.mcap --approach-deg 270", 'argument --approach-deg: approach_deg must be in [0, 180]'),
    ('simulate-detour-x', "simulate exp1 -o {tmp}/out.mcap --detour x", "argument --detour: must be a number, got 'x'"),
    ('record-duration-nan', "record --source sim:exp1 -o {tmp}/out.mcap --duration nan", "argument --duration: must be a finite number, got 'nan'"),
    ('record-duration-2', "record --source sim:exp1 -o {tmp}/out.mcap --duration -2", 'argument --duration: must be a number > 0'),
    ('record-duration-1e10', "record --source sim:locate -o {tmp}/out.mcap --duration 1e10", "argument --duration: must be at most 86400 s (24 h)"),
    ('record-video-duration-1e308', "record --source video:{tmp}/ok.avi --intrinsics {tmp}/camera.json -o {tmp}/out.mcap --duration 1e308", "argument --duration: must be at most 86400 s"),
    ('record-fps-0', "record --source sim:exp1 -o {tmp}/out.mcap --fps 0", "argument --fps: must be a number in [0.5, 120], got '0'"),
    ('record-fps-inf', "record --source sim:exp1 -o {tmp}/out.mcap --fps inf", 'argument --fps: must be a finite number'),
    ('record-hand-rate-0', "record --source sim:exp1 -o {tmp}/out.mcap --hand-rate 0", 'argument --hand-rate: must be a number in [0.1, 1000]'),
    ('record-seed-1', "record --source sim:exp1 -o {tmp}/out.mcap --seed -1", 'argument --seed: must be an integer in [0, 2**63 - 1]'),
    ('record-reference-size-0', "record --source sim:exp1 -o {tmp}/out.mcap --reference-size 0", 'argument --reference-size: must be a number > 0'),
    ('perception-train-epochs-0', "perception train -o {tmp}/out.pt --epochs 0", "argument --epochs: must be an integer >= 1, got '0'"),
    ('perception-train-samples-5', "perception train -o {tmp}/out.pt --samples -5", 'argument --samples: must be an integer >= 1'),
    ('perception-train-batch-0', "perception train -o {tmp}/out.pt --batch 0", 'argument --batch: must be an integer >= 1'),
    ('perception-train-lr-nan', "perception train -o {tmp}/out.pt --lr nan", 'argument --lr: must be a finite number'),
    ('perception-train-lr-0', "perception train -o {tmp}/out.pt --lr 0", 'argument --lr: must be a number > 0'),
    ('perception-train-threads-0', "perception train -o {tmp}/out.pt --threads 0", 'argument --threads: must be an integer >= 1'),
    ('perception-train-val-samples-0', "perception train -o {tmp}/out.pt --val-samples 0", 'argument --val-samples: must be an integer >= 1'),
    ('perception-train-seed-3', "perception train -o {tmp}/out.pt --seed -3", 'argument --seed: must be an integer in [0, 2**63 - 1]'),
    ('perception-eval-samples-0', 'perception eval --samples 0', 'argument --samples: must be an integer >= 1'),
    ('templates-train-params-fitnstates0', 'templates train {templates} -o {tmp}/t.json --params \'{"fit": {"n_states": 0}}\'', 'n_states must be >= 1'),
    ('templates-train-params-fitnstates2', 'templates train {templates} -o {tmp}/t.json --params \'{"fit": {"n_states": -2}}\'', 'template parameter `fit.n_states`'),
    ('templates-train-params-fitnstates4', 'templates train {templates} -o {tmp}/t.json --params \'{"fit": {"n_states": "4"}}\'', 'template parameter `fit.n_states`'),
    ('templates-train-params-fitnstates3000', 'templates train {templates} -o {tmp}/t.json --params \'{"fit": {"n_states": 3000}}\' --jobs 1', 'fit: n_states must be at most 64, got 3000'),
    ('templates-train-params-fitnmix1e6', 'templates train {templates} -o {tmp}/t.json --params \'{"fit": {"n_mix": 1000000}}\' --jobs 1', 'fit: n_mix must be at most 16, got 1000000'),
    ('templates-train-params-fitnstates4-2', 'templates train {templates} -o {tmp}/t.json --params \'{"fit": {"nstates": 4}}\'', 'unknown template parameter `fit.nstates`'),
    ('templates-train-params-allignfalse', 'templates train {templates} -o {tmp}/t.json --params \'{"allign": false}\'', 'unknown template parameter `allign`'),
    ('templates-train-params-fittolnan', 'templates train {templates} -o {tmp}/t.json --params \'{"fit": {"tol": NaN}}\'', 'template parameters are not plain JSON'),
    ('templates-train-params-rangepercent', 'templates train {templates} -o {tmp}/t.json --params \'{"range_percentiles": [99, 1]}\'', 'range_percentiles must be'),
    ('templates-train-params-dtwband0', 'templates train {templates} -o {tmp}/t.json --params \'{"dtw_band": 0}\'', 'dtw_band must be >= 1'),
    ('templates-train-params-12', "templates train {templates} -o {tmp}/t.json --params '[1, 2]'", 'must be a dict'),
    ('templates-train-params-fit1', "templates train {templates} -o {tmp}/t.json --params '{fit: 1}'", '--params is not valid JSON'),
    ('templates-show-binary-templates-binary', "templates show {binary}", 'is not a template file (binary'),
    ('templates-show-bad-json-templates-badjson', "templates show {badjson}", 'template file is not valid JSON'),
    ('templates-show-inverted-templates-inverted', "templates show {inverted}", 'range of column 0 is [1, 0], which is empty or inverted'),
    ('segment-binary-templates-binary', "segment {rec} --templates {binary} --json {tmp}/x.json", 'is not a template file'),
    ('segment-inverted-templates-inverted', "segment {rec} --templates {inverted} --json {tmp}/x.json", 'empty or inverted'),
]
# fmt: on


def _run(*argv: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "lfd.cli", *argv],
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )


def _fill(arg: str, values: dict[str, Path]) -> str:
    """``arg`` with every ``{name}`` placeholder replaced (other braces, e.g. JSON, kept)."""
    return re.sub(r"\{(\w+)\}", lambda m: str(values.get(m.group(1), m.group(0))), arg)


@pytest.fixture(scope="module")
def bad_templates(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    from lfd.segmentation import Templates

    d = tmp_path_factory.mktemp("bad_templates")
    (d / "binary.json").write_bytes(bytes(range(256)) * 4)
    (d / "bad.json").write_text('{"format_version": 1, "skills": [', encoding="utf-8")
    doc = json.loads(Templates.default().to_json())
    doc["ranges"][0] = [1.0, 0.0]
    (d / "inverted.json").write_text(json.dumps(doc), encoding="utf-8")
    return {"binary": d / "binary.json", "badjson": d / "bad.json", "inverted": d / "inverted.json"}


@pytest.fixture(scope="module")
def bad_labels(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Label files for exp1 (14.7 s, boxes box_1-3), each with one mistake."""
    d = tmp_path_factory.mktemp("bad_labels")
    files = {
        "overlap": "pick_up,0.5,2.0,box_2\nmove_with,1.5,3.0,box_2\n",
        "pastend": "skill,start_s,end_s,object\nmove,10,15.2,\n",
        "negative": "pick_up,-0.5,2.0,box_2\n",
        "inverted_labels": "pick_up,2.0,1.0,box_2\n",
        "unknownskill": "grab,0.5,2.0,box_2\n",
        "unknownobject": "pick_up,0.5,2.0,box_9\n",
        "nan_labels": "pick_up,nan,2.0,box_2\n",
    }
    for name, text in files.items():
        (d / f"{name}.csv").write_text(text, encoding="utf-8")
    return {name: d / f"{name}.csv" for name in files}


@pytest.fixture(scope="module")
def ros_inputs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A ROS 1 bag of exp1 (tests/_rosbags.py), its mapping and mappings with one mistake."""
    import lfd
    from _rosbags import write_ros1

    d = tmp_path_factory.mktemp("ros")
    text = write_ros1(lfd.load(EXP1, images=False), d / "exp1.bag")
    maps = {
        "bagmap": text,
        "map_missing": text.replace("/hand/keypoints", "/hand/kp"),
        "map_type": text.replace('topic = "/hand/keypoints"', 'topic = "/tf"'),
        "map_bad": text.replace('side = "right"', 'side = "both"'),
        "map_key": text.replace("[hand]", "[hnad]"),
    }
    for name, t in maps.items():
        (d / f"{name}.toml").write_text(t, encoding="utf-8")
    return {"bag": d / "exp1.bag", **{name: d / f"{name}.toml" for name in maps}}


def _tree(root: Path) -> dict[str, str]:
    """Every file under ``root`` (hidden ones included) -> a hash of its content."""
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def _assert_one_error_line(proc: subprocess.CompletedProcess[str], expected: str = "") -> str:
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("lfd "), lines[0]
    assert ": error: " in lines[0], lines[0]
    assert expected in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize(
    "where",
    # the default run calls main() here; the slow run also as a user runs it (~1 s per case)
    ["in-process", pytest.param("subprocess", marks=pytest.mark.slow)],
)
@pytest.mark.parametrize(("argv", "expected"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_user_error_is_one_line(
    argv: str,
    expected: str,
    where: str,
    tmp_path: Path,
    bad_templates: dict[str, Path],
    bad_labels: dict[str, Path],
    request: pytest.FixtureRequest,
    lfd_main: Callable[..., subprocess.CompletedProcess[str]],
) -> None:
    work = tmp_path / "work"
    work.mkdir()
    rec = work / "exp1.mcap"
    rec.write_bytes(EXP1.read_bytes())
    bad = work / "bad.json"
    bad.write_bytes(b"\x00\xff garbage {")
    ro = work / "ro"
    ro.mkdir()
    if "{ro}" in argv and os.geteuid() == 0:
        pytest.skip("root writes into read-only directories")
    ro.chmod(stat.S_IRUSR | stat.S_IXUSR)
    fill = {
        "rec": rec,
        "tmp": work,
        "ro": ro,
        "bad": bad,
        "docs": ROOT / "docs",
        "templates": ROOT / "recordings" / "templates",
        **bad_templates,
        **bad_labels,
        **(_still_inputs(work) if re.search(r"\{(photo|truncated|pixel)\}", argv) else {}),
        **(request.getfixturevalue("ros_inputs") if "{bag" in argv or "{map" in argv else {}),
    }
    before = _tree(work)
    try:
        args = [_fill(a, fill) for a in shlex.split(argv)]
        proc = _run(*args) if where == "subprocess" else lfd_main(args)
    finally:
        ro.chmod(stat.S_IRWXU)
    _assert_one_error_line(proc, expected)
    assert _tree(work) == before  # no input modified, no output nor temporary file left


def _still_inputs(work: Path) -> dict[str, Path]:
    """A 64x48 colour PNG, a 16-bit depth PNG of another size, an intrinsics file, the PNG cut
    in half and a 1x1 PNG."""
    import cv2
    import numpy as np

    cv2.imwrite(str(work / "photo.png"), np.full((48, 64, 3), 120, np.uint8))
    cv2.imwrite(str(work / "depth.png"), np.full((10, 10), 700, np.uint16))
    cv2.imwrite(str(work / "pixel.png"), np.full((1, 1, 3), 120, np.uint8))
    (work / "k.json").write_text('{"K": [[500, 0, 32], [0, 500, 24], [0, 0, 1]]}')
    png = (work / "photo.png").read_bytes()
    (work / "cut.png").write_bytes(png[: len(png) // 2])  # OpenCV warns on its own for these
    return {
        "photo": work / "photo.png",
        "depth": work / "depth.png",
        "k": work / "k.json",
        "truncated": work / "cut.png",
        "pixel": work / "pixel.png",
    }


def test_one_case_per_subcommand() -> None:
    import importlib

    from lfd.cli import COMMANDS

    covered = {c[1].split()[0] for c in CASES}
    assert covered == {importlib.import_module(f"lfd.cli.{m}").NAME for m in COMMANDS}
    perception = {c[1].split()[1] for c in CASES if c[1].startswith("perception ")}
    assert perception == {"train", "eval", "hands"}
    assert len({c[0] for c in CASES}) == len(CASES)  # ids are unique


@pytest.mark.parametrize(
    "argv",
    [
        "simulate exp1 -o {tmp}/x.mcap",
        "reproduce {rec}",
        "record --source sim:exp1 -o {tmp}/x.mcap --duration 1",
    ],
)
def test_without_sim_extra(argv: str, tmp_path: Path) -> None:
    """Without mujoco / cv2 / mink the simulator commands say how to install them, in one line."""
    code = (
        "import sys\n"
        "for m in ('mujoco', 'cv2', 'mink'): sys.modules[m] = None  # as if not installed\n"
        "from lfd.cli import main\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    args = [a.format(rec=EXP1, tmp=tmp_path) for a in shlex.split(argv)]
    proc = subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=60
    )
    cmd = args[0]
    line = _assert_one_error_line(proc)
    assert line == f"lfd {cmd}: error: this command needs the simulator: pip install 'lfd[sim]'"
    assert list(tmp_path.iterdir()) == []


def test_every_option_has_help() -> None:
    import argparse

    from lfd.cli import build_parser

    def walk(parser: argparse.ArgumentParser, prog: str) -> list[str]:
        missing = []
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    missing += walk(sub, f"{prog} {name}")
                continue
            if not action.help or action.help == argparse.SUPPRESS:
                missing.append(f"{prog} {'/'.join(action.option_strings) or action.dest}")
        return missing

    assert walk(build_parser(), "lfd") == []


def test_json_to_stdout_is_pure_json(tmp_path: Path) -> None:
    proc = _run("info", str(EXP1), "--json", "-")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["complete"] is True  # the tables went to stderr
    assert not Path("-").exists()


def test_broken_pipe_is_quiet() -> None:
    """``lfd info x.mcap --json - | head -1``: the reader goes away, no traceback."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "lfd.cli", "info", str(EXP1), "--json", "-"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()  # before anything was written: the write fails with EPIPE
    err = proc.stderr.read().decode()
    proc.stderr.close()
    proc.wait(timeout=60)
    assert proc.returncode in (0, 141), err
    assert "Traceback" not in err and "BrokenPipeError" not in err, err


def test_recovery_warning_is_one_line(tmp_path: Path) -> None:
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(EXP1.read_bytes()[: EXP1.stat().st_size * 3 // 4])
    proc = _run("segment", str(cut), "--json", str(tmp_path / "seg.json"))
    assert proc.returncode == 0, proc.stderr
    warnings = [line for line in proc.stderr.splitlines() if "warning" in line]
    assert warnings, proc.stderr
    assert all(line.startswith("lfd segment: warning: ") for line in warnings), proc.stderr
    assert "warnings.warn" not in proc.stderr and ".py:" not in proc.stderr  # no source line
    assert json.loads((tmp_path / "seg.json").read_text())["segments"]


def test_failing_write_leaves_no_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A write that fails midway (e.g. a full disk) leaves the destination absent or as it was."""
    import errno

    import lfd.outputs
    from lfd.cli import main

    def full_disk(fd: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(lfd.outputs.os, "fsync", full_disk)
    new = tmp_path / "new.json"
    old = tmp_path / "old.json"
    old.write_text("previous result")
    with pytest.raises(OSError, match="No space"):
        lfd.outputs.atomic_write_text(new, "x" * 100_000)
    assert not new.exists()
    # through the CLI: one line, exit 2, the previous file untouched, no temporary file
    assert main(["info", str(EXP1), "--json", str(old)]) == 2
    assert old.read_text() == "previous result"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.json"]


def test_rerun_save_written_at_close(
    tmp_path: Path, lfd_main: Callable[..., subprocess.CompletedProcess[str]]
) -> None:
    """``--rerun-save`` goes to a temporary file renamed at the end, so runs cannot interleave."""
    pytest.importorskip("rerun", reason="rerun-sdk not installed (optional viz extra)")
    rrd = tmp_path / "seg.rrd"
    rrd.write_bytes(b"previous")
    proc = lfd_main(["segment", EXP1, "--rerun-save", rrd])
    assert proc.returncode == 0, proc.stderr
    assert rrd.stat().st_size > 10_000 and not rrd.read_bytes().startswith(b"previous")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["seg.rrd"]


@pytest.mark.slow  # two segmentations with Rerun in racing subprocesses
def test_two_runs_writing_one_rrd_leave_a_readable_file(tmp_path: Path) -> None:
    """Two commands saving to the same ``.rrd`` at once: the last rename wins, whole."""
    rr = pytest.importorskip("rerun", reason="rerun-sdk not installed (optional viz extra)")
    rrd = tmp_path / "same.rrd"
    argv = [sys.executable, "-m", "lfd.cli", "segment", str(EXP1), "--rerun-save", str(rrd)]
    procs = [
        subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE) for _ in "ab"
    ]
    for p in procs:
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
    reader = rr.chunk.RrdReader(rrd)
    entities = {chunk.entity_path for chunk in reader.stream()}  # decodes from start to end
    assert "/segmentation/skills/result" in entities
    assert sorted(p.name for p in tmp_path.iterdir()) == ["same.rrd"]
