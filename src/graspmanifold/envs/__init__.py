"""Gymnasium environments of the library's tasks (`pip install 'graspmanifold[envs]'`): importing this package
registers `graspmanifold/TactileGrasp-v0` (`gymnasium.make("graspmanifold/TactileGrasp-v0", object="box")`, and
`gymnasium.make_vec(..., vectorization_mode="vector_entry_point")` for N worlds at once)."""

try:
    import gymnasium
except ImportError as error:  # an optional extra
    raise ImportError("graspmanifold.envs needs Gymnasium: pip install 'graspmanifold[envs]'") from error

from .tactile_grasp import TactileGraspEnv, TactileGraspVectorEnv

TACTILE_GRASP = "graspmanifold/TactileGrasp-v0"
if TACTILE_GRASP not in gymnasium.registry:
    gymnasium.register(id=TACTILE_GRASP, entry_point="graspmanifold.envs.tactile_grasp:TactileGraspEnv",
                       vector_entry_point="graspmanifold.envs.tactile_grasp:TactileGraspVectorEnv")

__all__ = ["TACTILE_GRASP", "TactileGraspEnv", "TactileGraspVectorEnv"]
