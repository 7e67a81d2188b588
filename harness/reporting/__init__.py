"""The engineer's answers of a run: its engineering quantities (:mod:`~harness.reporting.quantities`, their
expressions :mod:`~harness.reporting.qoi`), its charts (:mod:`~harness.reporting.charts` decides what each figure shows,
:mod:`~harness.reporting.chartdraw` draws it) and the self-contained HTML report (:mod:`~harness.reporting.htmlreport`)."""
