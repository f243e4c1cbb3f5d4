"""The default Rerun layout of lfd recordings and the entity paths it shows.

Entity paths (see the ``log_*`` functions for what each holds)::

    /world                                 3-D scene, reference-marker frame, Z up
    /world/reference_marker                tag 0: axes and outline
    /world/hand/keypoints                  21 keypoints, skeleton from the AnnotationContext
    /world/hand/path                       the raw TCP path (I + T) / 2
    /world/gripper                         preprocessed TCP frame (+ trail, opening)
    /world/tcp_path                        preprocessed TCP path
    /world/hand/<side>/...                 of two hands, each: keypoints, path, gripper,
                                           tcp_path, gripper_trail (its own skeleton colour)
    /world/handovers/<source>              where each handover took place (labelled points)
    /world/objects/<name>                  object frame; /box: Boxes3D labelled with the tag id
    /world/camera/image                    pinhole; /rgb colour, /depth depth (mm)
    /world/robot/<mode>                    planned/executed TCP paths, arm, current TCP
    /world/robot_objects/<mode>/<name>     objects as the reproduction moved them (robot_time)
    /features/<name>/value|threshold       Table I features with their stage-1 thresholds
    /features/target                       target object per sample (state)
    /segmentation/sections                 stage-1 data sections (state)
    /segmentation/skills/<source>          skill spans: result, ground_truth, baselines (state)
    /segmentation/skills/<side>/<source>   of two hands, each hand's lanes
    /segmentation/handovers/<source>       handovers: result, ground_truth (state)
    /segmentation/greedy/...               stage-2 HMM scores per skill and greedy iteration
    /segmentation/log, /segmentation/warnings   text logs
    /robot/<mode>/...                      reproduction time series (robot_time)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..features import FEATURE_NAMES  # the ten feature columns of Table I, one plot each
from .recording import import_rerun
from .timeline import DEMO_TIME


def default_blueprint(
    *,
    feature_names: Sequence[str] = FEATURE_NAMES,
    camera: bool = True,
    timeline: str = DEMO_TIME,
) -> Any:
    """The default layout: 3-D scene and camera left, skill timelines and plots right.

    Parameters
    ----------
    feature_names : sequence of str
        One time-series plot per feature (``/features/<name>``).
    camera : bool
        Include the colour and depth image views.
    timeline : str
        The timeline selected in the time panel.

    Returns
    -------
    rerun.blueprint.Blueprint
    """
    import_rerun()
    import rerun.blueprint as rrb

    scene = rrb.Spatial3DView(
        origin="/world",
        # the depth point cloud hides the hand; it is one click away in the blueprint panel
        # (objects moved by a reproduction live on robot_time: its own view below)
        contents=["+ $origin/**", "- /world/camera/image/depth", "- /world/robot_objects/**"],
        name="Scene (reference marker frame)",
    )
    left: Any = scene
    if camera:
        images = rrb.Horizontal(
            rrb.Spatial2DView(origin="/world/camera/image", contents="$origin/rgb", name="Colour"),
            rrb.Spatial2DView(
                origin="/world/camera/image", contents="$origin/depth", name="Depth (mm)"
            ),
        )
        left = rrb.Vertical(scene, images, row_shares=[3, 1])

    states = rrb.StateTimelineView(
        origin="/",
        contents=[
            "+ /segmentation/skills/**",
            "+ /segmentation/handovers/**",
            "+ /segmentation/sections",
            "+ /features/target",
            "+ /robot/*/segment",
        ],
        name="Skills (result, ground truth, baselines; per hand), handovers, sections",
    )
    features = rrb.Grid(
        *[
            # blue: the feature, red: its stage-1 threshold (legend hidden: the plots are small)
            rrb.TimeSeriesView(
                origin=f"/features/{name}", name=name, plot_legend=rrb.PlotLegend(visible=False)
            )
            for name in feature_names
        ],
        grid_columns=2,
        name="Features",
    )
    scores = rrb.TimeSeriesView(
        # one line per (greedy iteration, skill) in the skill's lane colour; white: the cuts
        origin="/segmentation/greedy",
        name="HMM scores",
        plot_legend=rrb.PlotLegend(visible=False),
    )
    logs = rrb.TextLogView(
        origin="/", contents=["+ /segmentation/**", "+ /robot/**"], name="Log and warnings"
    )
    robot = rrb.Vertical(
        # switch the time panel to robot_time to play a reproduction
        rrb.Spatial3DView(
            origin="/world",
            contents=[
                "+ /world/robot/**",
                "+ /world/robot_objects/**",
                "+ /world/reference_marker/**",
            ],
            name="Reproduction 3-D",
        ),
        rrb.TimeSeriesView(origin="/robot", name="Tracking error, opening"),
        row_shares=[2, 1],
        name="Reproduction",
    )
    right = rrb.Vertical(
        states,
        rrb.Tabs(features, scores, logs, robot, active_tab=0),
        row_shares=[1, 2],
    )
    return rrb.Blueprint(
        rrb.Horizontal(left, right, column_shares=[1, 1]),
        rrb.TimePanel(timeline=timeline),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
    )
