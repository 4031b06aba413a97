"""Plant data in: historian exports (CSV, Parquet) read, placed on the sample grid and cleaned, with counts.

``load_plant_data(path, config)`` gives :class:`PlantData`, whose
``stretches()`` are what :func:`pmr_ros.core.pmr.diagnosis.diagnose_stretches`
diagnoses as one estimate.  pandas and pyarrow are imported only when a file
is read (the ``data`` extra).
"""

from .bad_data import DataError
from .clean import CleaningStep, PlantData
from .load import load_plant_data
from .read import FORMATS, table_format

__all__ = ["FORMATS", "CleaningStep", "DataError", "PlantData", "load_plant_data", "table_format"]
