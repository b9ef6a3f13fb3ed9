"""Diagnosis of measured friction data: what the base model gets wrong, the physical
cause from the catalogue of physics.md section 5, the extended model and its gain."""

from nanoblock.diagnosis.catalogue import CATALOGUE
from nanoblock.diagnosis.core import Diagnosis, diagnose
from nanoblock.diagnosis.validation import DiagnosisError, load_for_diagnosis

__all__ = ["CATALOGUE", "Diagnosis", "DiagnosisError", "diagnose", "load_for_diagnosis"]
