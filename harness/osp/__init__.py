"""OSP's own files (Open Simulation Platform: libcosim, Ecos): ``OspSystemStructure.xml`` with an
``<Model>_OspModelDescription.xml`` per FMU, in and out, and libcosim's scenario files.

``harness.osp.read``      :func:`load_osp` (an OspSystemStructure.xml or a folder holding one -> System);
``harness.osp.write``     :func:`export_osp` (a system -> an OspSystemStructure.xml, one OspModelDescription per
                          FMU whose mechanical ports are the drive's power bonds, the FMUs beside them);
``harness.osp.scenario``  libcosim's scenario files (events of override, bias and reset on a model's variable).
"""
from harness.osp.read import MODEL_DESCRIPTION, STRUCTURE, is_osp_structure, load_osp, read_model_description

__all__ = ["load_osp", "is_osp_structure", "read_model_description", "STRUCTURE", "MODEL_DESCRIPTION"]
