"""What the SSP export and import share: the XML namespaces (registered once) and the type and annotation names."""
from __future__ import annotations

from xml.etree import ElementTree as ET

from harness.ssp.values import NS

for _prefix, _uri in NS.items():
    ET.register_namespace(_prefix, _uri)

OSP_ANNOTATION = "com.opensimulationplatform"
OWN_ANNOTATION = "org.pressdrive"
FMU_TYPE = "application/x-fmu-sharedlibrary"
PARAMETER_SET = "default"
PARAMETER_SET_TYPE = "application/x-ssp-parameter-set"
PARAMETER_MAPPING_TYPE = "application/x-ssp-parameter-mapping"
