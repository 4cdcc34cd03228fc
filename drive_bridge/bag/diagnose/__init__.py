"""Diagnosis of a recorded bus: one pass over the frames, one module per concern.

``diagnose(recording, inputs)`` feeds every frame once to the analysers (dispatched by COB-ID),
then each analyser turns what it saw into report sections and findings (see ``engine``).
"""
from __future__ import annotations

from drive_bridge.bag.diagnose.engine import Diagnosis, diagnose
from drive_bridge.bag.diagnose.inputs import DiagnoseInputs, load_inputs
from drive_bridge.bag.diagnose.model import Finding, Severity

__all__ = ['Diagnosis', 'DiagnoseInputs', 'Finding', 'Severity', 'diagnose', 'load_inputs']
