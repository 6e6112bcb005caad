"""Material-point constitutive models (UMAT equivalents) and laboratory-test drivers.

Compression positive, effective stresses in kPa, Voigt order (11, 22, 33, 12, 23, 31) with engineering shear.
See :mod:`constitutive.base` for the interface every model follows.
"""
from .anicreep import ANICREEP
from .base import IntegrationError, MaterialModel, ParameterError
from .elastic import LinearElastic
from .mcc import ModifiedCamClay
from .sand.simsand import SIMSAND
from .von_mises import VonMises

__all__ = ["IntegrationError", "MaterialModel", "ParameterError", "LinearElastic", "VonMises", "ModifiedCamClay",
           "ANICREEP", "SIMSAND"]
