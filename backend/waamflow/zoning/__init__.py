"""MPP zoning: zones along section paths and the XML deposition-parameter file (Michel et al. 2019)."""

from .params_xml import ParamTable, merge, parse, template, validate_xml
from .zones import ZoneSpec, apply_zone_params, zone_color, zone_lengths, zone_path

__all__ = [
    "ParamTable",
    "ZoneSpec",
    "apply_zone_params",
    "merge",
    "parse",
    "template",
    "validate_xml",
    "zone_color",
    "zone_lengths",
    "zone_path",
]
