"""System identification: from a lab's measurements to a device, its uncertainty and the fit's quality.

Output error on the exact sampled model of the analyses (models/plants.stiffness_loop_plant: ZOH and
fractional delay), or a weighted complex fit of a measured frequency response.  Entry point:
:func:`optim.identification.identify.identify`.
"""

from optim.identification.data import FrequencyResponseData, TimeSeriesData
from optim.identification.identify import identify
from optim.identification.result import IdentificationResult

__all__ = ["FrequencyResponseData", "IdentificationResult", "TimeSeriesData", "identify"]
