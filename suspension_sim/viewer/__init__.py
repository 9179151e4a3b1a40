"""Browser 3D view of a run with meshcat: live while simulating, or recorded into a self-contained ``viewer.html``.

The scene is drawn from what a run logs (the :class:`~suspension_sim.results.Result` time series and ``info``:
corner suffixes and positions, static loads, bump-stop gaps), so it works for every model: SDOF rig, quarter,
half and full car.  What it shows (display sizes are fixed, only motions come from the run):

- the **body** (blue box) heaving, pitching (positive = nose down) and rolling (positive = right side down);
- the **wheels** (dark cylinders with light spokes) moving with ``wheel_z{s}`` and turning with the distance
  travelled (angle = distance / display radius);
- the **suspension springs** (coils between wheel and body, beside each wheel) whose length is the display
  length plus the suspension travel, coloured green → yellow → red as ``|travel|`` approaches the bump-stop gap
  (``info['stop_gap']``; a run without bump stops uses :data:`DEFAULT_GAP`, shown in the legend);
- **actuator force arrows** (orange, beside the body at each corner) pointing up for a force pushing the body up,
  :data:`ARROW_PER_N` m per newton (0.3 m per kN, at most :data:`ARROW_MAX`);
- the **road** with its real profile passing under the car (the car stays at x = 0, the road moves by the
  distance travelled, so on a half or full car the rear wheels meet a bump later), drawn from the road heights
  logged under every wheel; a rig input without travel (speed 0) is drawn as plates moving under the wheels;
- a red **lift-off marker** under a wheel whenever its total tire force (static + ``tire_force{s}``) is <= 0;
- the **time** on screen and **camera presets** (:data:`CAMERAS`).

Two outputs share that scene:

- :func:`write_viewer` records a meshcat animation into a static page: meshcat's own JavaScript bundle is
  embedded and the scene is fed to it as msgpack commands decoded in the page (the same thing meshcat's
  ``static_html`` produces, without starting its server), so the page opens offline from disk and can be mailed.
  It adds a small overlay (time, play/pause, scrub slider, speed, camera presets, legend) and a JavaScript hook,
  ``window.suspensionSim`` (``seek(t)``, ``play()``, ``pause()``, ``time()``, ``camera(name)``, ``duration``), also
  driven by the URL fragment ``#t=1.5`` (show that time, paused) and ``#camera=side``.
- :func:`attach_live_viewer` streams a running :class:`~suspension_sim.simulation.Simulation` to a meshcat
  server bound to 127.0.0.1 (its URL printed), at real time or a chosen rate, through the simulation's
  ``log_hooks``.

The package: :mod:`.scene` (what is drawn), :mod:`.sources` (scenes from results and simulations),
:mod:`.recording` (``viewer.html``) and :mod:`.live` (the live server and the replay of a finished run).
"""
from __future__ import annotations

from .live import LiveServer, LiveView, attach_live_viewer, replay_live
from .recording import (animation_commands, base_commands, build_html, camera_commands, camera_position, meshcat_js,
                        write_compare_viewer, write_viewer)
from .scene import (ARROW_COLOR, ARROW_LENGTH, ARROW_MAX, ARROW_PER_N, BACKGROUND, BODY_COLOR, BODY_H, BODY_Z, CAMERAS,
                    DEFAULT_GAP, GROUND_COLOR, LIFTOFF_COLOR, ROAD_COLOR, ROAD_DEPTH, ROAD_DX, ROAD_POINTS, ROAD_STRIPE,
                    ROOT, SPOKE_COLOR, SPRING_R, TARGET_Z, TIRE_COLOR, TIRE_W, WHEEL_R, CarScene, RoadProfile,
                    usage_color)
from .sources import (choose_fps, distance_function, frame_times, road_profile_from_log, road_profile_from_sim,
                      sample_columns, scene_from_result)

__all__ = ["LiveServer", "LiveView", "attach_live_viewer", "replay_live", "animation_commands", "base_commands",
           "build_html", "camera_commands", "camera_position", "meshcat_js", "write_compare_viewer", "write_viewer",
           "ARROW_COLOR", "ARROW_LENGTH", "ARROW_MAX", "ARROW_PER_N", "BACKGROUND", "BODY_COLOR", "BODY_H", "BODY_Z",
           "CAMERAS", "DEFAULT_GAP", "GROUND_COLOR", "LIFTOFF_COLOR", "ROAD_COLOR", "ROAD_DEPTH", "ROAD_DX",
           "ROAD_POINTS", "ROAD_STRIPE", "ROOT", "SPOKE_COLOR", "SPRING_R", "TARGET_Z", "TIRE_COLOR", "TIRE_W",
           "WHEEL_R", "CarScene", "RoadProfile", "usage_color", "choose_fps", "distance_function", "frame_times",
           "road_profile_from_log", "road_profile_from_sim", "sample_columns", "scene_from_result"]
