"""Tabular Q-learning, the paper's agent: discretise observations, learn one Q-table per env."""

from modelicagym.agents.discretization import CARTPOLE_INTERVALS, Discretizer
from modelicagym.agents.qlearning import QLearningAgent, QLearningConfig
from modelicagym.agents.training import TrainingLog, train

__all__ = [
    "CARTPOLE_INTERVALS",
    "Discretizer",
    "QLearningAgent",
    "QLearningConfig",
    "TrainingLog",
    "train",
]
