"""The survey: the station's state machine (``machine``) and what it leans on: the approach
between stations, acquisition of tiles and chips, registration to the station it was aimed
from, memory across stations, the analysis's points, the session's report, the site."""

from ..vision.contract import AnalysisJob
from .approach import station_geometry
from .machine import Survey, SurveyBusyError, SurveyState, SurveyTelemetry

__all__ = [
    "AnalysisJob",
    "Survey",
    "SurveyBusyError",
    "SurveyState",
    "SurveyTelemetry",
    "station_geometry",
]
