"""The trial's names where 0.2 had them, for one release: `trials/trial.py` held seven ideas and is now four rooms,
the set-up (`setup`: `TrialSetup`, `Noise`), the record (`record`: `Trial`), the episode (`episode`: where a trial
starts, the loop, `run_trials`) and the recording (`recording`: `record_trial`). Import from those; this face goes in
0.3 (`base.moved.REMOVED_IN`).
"""

from .episode import (MAX_GRASP_SECONDS, ORACLE_SETTLE_SECONDS, EpisodeWorlds, flange_targets, run_trial, run_trials,
                      start_worlds, trial_scene, trial_starts)
from .record import FAILURE_FEATURES, FIRST_CONTACT_FEATURES, Trial
from .recording import RECORDED_POSE, Recording, record_trial
from .setup import BACKENDS, MAX_NOISE, ORACLES, WARP_BATCH, Noise, TrialSetup, method_name

Episodes = EpisodeWorlds  # 0.2's name of EpisodeWorlds, this face's for one release

__all__ = ["MAX_GRASP_SECONDS", "ORACLE_SETTLE_SECONDS", "EpisodeWorlds", "Episodes", "flange_targets", "run_trial", "run_trials",
           "start_worlds", "trial_scene", "trial_starts", "FAILURE_FEATURES", "FIRST_CONTACT_FEATURES", "Trial",
           "RECORDED_POSE", "Recording", "record_trial", "BACKENDS", "MAX_NOISE", "ORACLES", "WARP_BATCH", "Noise",
           "TrialSetup", "method_name"]
