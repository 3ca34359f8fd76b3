"""The model-based reasoner: window features and fault curves, classifier, EKF, SoH and RUL.

* :mod:`~mapr_daemon.reasoner.features` — the paper's window features and the matrix M.
* :mod:`~mapr_daemon.reasoner.curves` — N, G, V, chosen curves, PCA new values, descent.
* :mod:`~mapr_daemon.reasoner.dictionary` / :mod:`~mapr_daemon.reasoner.build` — the fault
  dictionary file and how it is built and calibrated.
* :mod:`~mapr_daemon.reasoner.classifier` — anomaly, fault mode, severity, confidence.
* :mod:`~mapr_daemon.reasoner.corpus` — batched BIT runs and ``mapr simulate`` files.
"""
