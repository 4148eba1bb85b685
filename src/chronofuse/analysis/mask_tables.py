"""ITU-T wander and time-error limits as data: one entry per clock class or network reference point.

Each MTIE or TDEV row is ``(tau_lo_s, tau_hi_s, limit, source[, ends])`` with ``limit`` a tuple of
``(coefficient_ns, power)`` terms, ``limit_ns = sum c tau**p``, on ``tau_lo < tau <= tau_hi`` unless
``ends`` writes the interval otherwise as the table does (``"[]"``, ``"()"``, ``"[)"``; ``"(]"`` is the
default); ``"m"`` as the lower end is the tables' ``m``, the record's sample interval. :mod:`chronofuse.analysis.masks` builds the masks from these.

Where the numbers come from (the ITU-T texts themselves could not be read from this project; each row is
a transcription, named with the table it transcribes, and the tests re-evaluate every breakpoint):

- G.8272 (PRTC-A/B) and G.811 (PRC): the project's earlier transcription, cross-checked against
  allantools' (``allantools.mask``).
- G.8272.1 (ePRTC, locked): Tables 1 and 2, clause 6.1, as transcribed (2024 edition, Amd. 1 (07/2025),
  read on itu.int) in the public ``kshana`` project's ``docs/TELECOM-TIMING.md``; the MTIE and TDEV rows
  agree with A. Wallin's independent transcription (``aewallin`` gist "TDEV and MTIE masks for ITU
  standards", 2017-2018) except its first MTIE row (1 ns there, 4 ns here: 4 ns is the value the second
  row's ``0.11114 tau + 3.89`` reaches at 1 s, so the mask is continuous).
- G.8273.2 (T-BC/T-TSC classes A-D): Tables 7-1 to 7-7 as transcribed in ``kshana`` (2023 edition,
  Amd. 2 (11/2025)), agreeing with Calnex's one-page summary of G.8273.2 (2nd edition 2020 with Amds. 1
  and 2) on every limit both give.
- G.8271.1 (network limits at reference point C, deployment case 1): Tables 7-1 to 7-3, clause 7.3, as
  transcribed in ``kshana`` (2022 edition, Amd. 3 (05/2025)). No second transcription was found.
- G.8262 (EEC options 1 and 2, wander generation): Tables 1 to 5 of the 07/2010 edition, as transcribed
  in R. Smiley's ``timetools`` (``compliance/ituTG8262``). No second transcription was found.

Not here, because no text of their tables was found (none is invented): G.8262.1 (eEEC), G.813 (SEC),
G.812 (SSU), G.823 and G.824 (network limits of the 2048 and 1544 kbit/s hierarchies). Searched twice
(the second time on 2026-12-02, docs/stability.md section 6 says where): tables of contents and
summaries only, and no open-source transcription with a second one to check it against.
"""

from __future__ import annotations

INF = float("inf")

_PRTC_MTIE_SLOPE = ((25.0, 0.0), (0.275, 1.0))  # 0.275e-3 tau + 0.025 us, in ns

TABLES: dict[str, dict] = {
    # --- G.8272 and G.811: the three masks this module started with (the last row extended without end).
    "prtc-a": {
        "title": "PRTC-A, primary reference time clock class A (ITU-T G.8272)",
        "reference": "ITU-T G.8272 (11/2018) clause 6.1",
        "max_abs_te_ns": (100.0, "ITU-T G.8272 clause 6.1"),
        "mtie": [(0.1, 273.0, _PRTC_MTIE_SLOPE, "ITU-T G.8272 Table 1"),
                 (273.0, INF, ((100.0, 0.0),), "ITU-T G.8272 Table 1")],
        "tdev": [(0.1, 100.0, ((3.0, 0.0),), "ITU-T G.8272 Table 3"),
                 (100.0, 1000.0, ((0.03, 1.0),), "ITU-T G.8272 Table 3"),
                 (1000.0, INF, ((30.0, 0.0),), "ITU-T G.8272 Table 3")],
    },
    "prtc-b": {
        "title": "PRTC-B, primary reference time clock class B (ITU-T G.8272)",
        "reference": "ITU-T G.8272 (11/2018) clause 6.1",
        "max_abs_te_ns": (40.0, "ITU-T G.8272 clause 6.1"),
        "mtie": [(0.1, 54.5, _PRTC_MTIE_SLOPE, "ITU-T G.8272 Table 2"),
                 (54.5, INF, ((40.0, 0.0),), "ITU-T G.8272 Table 2")],
        "tdev": [(0.1, 100.0, ((1.0, 0.0),), "ITU-T G.8272 Table 4"),
                 (100.0, 500.0, ((0.01, 1.0),), "ITU-T G.8272 Table 4"),
                 (500.0, INF, ((5.0, 0.0),), "ITU-T G.8272 Table 4")],
    },
    "g811": {
        "title": "PRC, primary reference clock (ITU-T G.811)",
        "reference": "ITU-T G.811 (1997) Amd. 1 (2016)",
        "mtie": [(0.1, 1000.0, _PRTC_MTIE_SLOPE, "ITU-T G.811 Table 1"),
                 (1000.0, INF, ((290.0, 0.0), (0.01, 1.0)), "ITU-T G.811 Table 1")],
        "tdev": [(0.1, 100.0, ((3.0, 0.0),), "ITU-T G.811 Table 2"),
                 (100.0, 1000.0, ((0.03, 1.0),), "ITU-T G.811 Table 2"),
                 (1000.0, INF, ((30.0, 0.0),), "ITU-T G.811 Table 2")],
    },
    # --- G.8272.1: ePRTC in locked mode.
    "eprtc": {
        "title": "ePRTC, enhanced primary reference time clock, locked (ITU-T G.8272.1)",
        "reference": "ITU-T G.8272.1 (2024) Amd. 1 (07/2025) clauses 6.1, 6.2",
        "max_abs_te_ns": (30.0, "ITU-T G.8272.1 clause 6.1"),
        "mtie": [(0.1, 1.0, ((4.0, 0.0),), "ITU-T G.8272.1 Table 1"),
                 (1.0, 100.0, ((3.89, 0.0), (0.11114, 1.0)), "ITU-T G.8272.1 Table 1"),
                 (100.0, 400_000.0, ((15.0, 0.0), (0.0375e-3, 1.0)), "ITU-T G.8272.1 Table 1"),
                 (400_000.0, INF, ((30.0, 0.0),), "ITU-T G.8272.1 Table 1")],
        "tdev": [(0.1, 30_000.0, ((1.0, 0.0),), "ITU-T G.8272.1 Table 2"),
                 (30_000.0, 300_000.0, ((3.33333e-5, 1.0),), "ITU-T G.8272.1 Table 2"),
                 (300_000.0, 1_000_000.0, ((10.0, 0.0),), "ITU-T G.8272.1 Table 2", "()")],
        "not_specified": "phase discontinuity (clause 7) is for further study",
    },
    # --- G.8273.2: T-BC and T-TSC, noise generation in locked mode. MTIE and TDEV are of dTE_L (0.1 Hz
    # low-pass), max |TE| unfiltered, cTE averaged over 1000 s, dTE_H peak to peak after the high-pass.
    **{
        f"t-bc-{cls}": {
            "title": f"T-BC/T-TSC class {cls.upper()}, constant temperature (ITU-T G.8273.2)",
            "reference": "ITU-T G.8273.2 (2023) Amd. 2 (11/2025) clause 7.1",
            "filtered": True,
            "max_abs_te_ns": (te, "ITU-T G.8273.2 Table 7-1"),
            "cte_ns": (cte, "ITU-T G.8273.2 Table 7-3"),
            "dte_h_pp_ns": (dte_h, "ITU-T G.8273.2 Table 7-7"),
            "mtie": [("m", 1000.0, ((mtie, 0.0),), "ITU-T G.8273.2 Table 7-4", "[]")],
            "tdev": [("m", 1000.0, ((tdev, 0.0),), "ITU-T G.8273.2 Table 7-5", tdev_lo)],
            "not_specified": "phase/time holdover with both inputs lost is for further study",
        }
        for cls, te, cte, mtie, tdev, dte_h, tdev_lo in (
            ("a", 100.0, 50.0, 40.0, 4.0, 70.0, "(]"),  # Table 7-5 writes m < tau <= 1000 for A and B
            ("b", 70.0, 20.0, 40.0, 4.0, 70.0, "(]"),
            ("c", 30.0, 10.0, 10.0, 2.0, 30.0, "[]"),  # and m <= tau <= 1000 for C
        )
    },
    "t-bc-d": {
        "title": "T-BC/T-TSC class D (ITU-T G.8273.2)",
        "reference": "ITU-T G.8273.2 (2023) Amd. 2 (11/2025) clause 7.1",
        "filtered": True,
        "max_abs_te_l_ns": (5.0, "ITU-T G.8273.2 Table 7-2"),
        "not_specified": "class D max |TE|, cTE, dTE_L MTIE and TDEV, dTE_H and holdover are for further study",
    },
    **{
        f"t-bc-{cls}-vartemp": {
            "title": f"T-BC/T-TSC class {cls.upper()}, variable temperature (ITU-T G.8273.2)",
            "reference": "ITU-T G.8273.2 (2023) Amd. 2 (11/2025) clause 7.1",
            "filtered": True,
            "mtie": [("m", 10_000.0, ((mtie, 0.0),), "ITU-T G.8273.2 Table 7-6", "[]")],
            "not_specified": "TDEV with variable temperature is not specified",
        }
        for cls, mtie in (("a", 40.0), ("b", 40.0), ("c", 10.0))
    },
    # --- G.8271.1: network limits at reference point C (deployment case 1), after the 0.1 Hz low-pass.
    "g8271.1-c": {
        "title": "network limit at reference point C (ITU-T G.8271.1 clause 7.3.1)",
        "reference": "ITU-T G.8271.1 (2022) Amd. 3 (05/2025) clause 7.3.1",
        "filtered": True,
        "max_abs_te_l_ns": (1100.0, "ITU-T G.8271.1 clause 7.3.1"),
        "mtie": [(1.3, 2.4, ((100.0, 0.0), (75.0, 1.0)), "ITU-T G.8271.1 Table 7-1"),
                 (2.4, 275.0, ((277.0, 0.0), (1.1, 1.0)), "ITU-T G.8271.1 Table 7-1"),
                 (275.0, 10_000.0, ((580.0, 0.0),), "ITU-T G.8271.1 Table 7-1")],
        "not_specified": "the TDEV network limit at reference point C is for further study",
    },
    "g8271.1-c-enhanced": {
        "title": "enhanced network limit at reference point C (ITU-T G.8271.1 clause 7.3.2)",
        "reference": "ITU-T G.8271.1 (2022) Amd. 3 (05/2025) clause 7.3.2",
        "filtered": True,
        "max_abs_te_l_ns": (600.0, "ITU-T G.8271.1 clause 7.3.2"),
        "mtie": [(1.3, 2.4, ((37.39, 0.0), (9.7, 1.0)), "ITU-T G.8271.1 Table 7-2"),
                 (2.4, 20.2, ((55.27, 0.0), (2.25, 1.0)), "ITU-T G.8271.1 Table 7-2"),
                 (20.2, 211.11, ((90.22, 0.0), (0.52, 1.0)), "ITU-T G.8271.1 Table 7-2"),
                 (211.11, 10_000.0, ((200.0, 0.0),), "ITU-T G.8271.1 Table 7-2")],
        "not_specified": "the TDEV network limit at reference point C is for further study",
    },
    "g8271.1-c-access": {
        "title": "network limit at reference point C, PRTC in the access network (ITU-T G.8271.1 clause 7.3.3)",
        "reference": "ITU-T G.8271.1 (2022) Amd. 3 (05/2025) clause 7.3.3",
        "filtered": True,
        "max_abs_te_l_ns": (100.0, "ITU-T G.8271.1 clause 7.3.3"),
        # The table writes "1 < tau < 400" and "400 < tau <= 10 000": tau = 400 s itself has no limit.
        "mtie": [(1.0, 400.0, ((25.0, 0.0), (0.0475, 1.0)), "ITU-T G.8271.1 Table 7-3", "()"),
                 (400.0, 10_000.0, ((44.0, 0.0),), "ITU-T G.8271.1 Table 7-3")],
        "not_specified": "the TDEV network limit at reference point C is for further study",
    },
    # --- G.8262: EEC wander generation (SyncE), no measurement filter applied here.
    "g8262-opt1": {
        "title": "EEC option 1, wander generation at constant temperature (ITU-T G.8262)",
        "reference": "ITU-T G.8262/Y.1362 (07/2010) clause 8.1",
        "mtie": [(0.1, 1.0, ((40.0, 0.0),), "ITU-T G.8262 Table 1"),
                 (1.0, 100.0, ((40.0, 0.1),), "ITU-T G.8262 Table 1"),
                 (100.0, 1000.0, ((25.25, 0.2),), "ITU-T G.8262 Table 1")],
        "tdev": [(0.1, 25.0, ((3.2, 0.0),), "ITU-T G.8262 Table 3"),
                 (25.0, 100.0, ((0.64, 0.5),), "ITU-T G.8262 Table 3"),
                 (100.0, 1000.0, ((6.4, 0.0),), "ITU-T G.8262 Table 3")],
    },
    "g8262-opt1-temp": {
        "title": "EEC option 1, wander generation MTIE with temperature effects (ITU-T G.8262)",
        "reference": "ITU-T G.8262/Y.1362 (07/2010) clause 8.1",
        "mtie": [(0.1, 1.0, ((40.0, 0.0), (0.5, 1.0)), "ITU-T G.8262 Table 2"),
                 (1.0, 100.0, ((40.0, 0.1), (0.5, 1.0)), "ITU-T G.8262 Table 2"),
                 (100.0, 1000.0, ((50.0, 0.0), (25.25, 0.2)), "ITU-T G.8262 Table 2")],
        "not_specified": "TDEV with temperature effects is not specified (Table 3 is at constant temperature)",
    },
    "g8262-opt2": {
        "title": "EEC option 2, wander generation (ITU-T G.8262)",
        "reference": "ITU-T G.8262/Y.1362 (07/2010) clause 8.2",
        "mtie": [(0.1, 1.0, ((20.0, 0.0),), "ITU-T G.8262 Table 4"),
                 (1.0, 10.0, ((20.0, 0.48),), "ITU-T G.8262 Table 4"),
                 (10.0, 1000.0, ((60.0, 0.0),), "ITU-T G.8262 Table 4")],
        "tdev": [(0.1, 2.5, ((3.2, -0.5),), "ITU-T G.8262 Table 5"),
                 (2.5, 40.0, ((2.0, 0.0),), "ITU-T G.8262 Table 5"),
                 (40.0, 1000.0, ((0.32, 0.5),), "ITU-T G.8262 Table 5"),
                 (1000.0, 10_000.0, ((10.0, 0.0),), "ITU-T G.8262 Table 5")],
    },
}

#: Recommendations asked for whose tables were not available to transcribe (nothing of them is implemented).
NOT_TRANSCRIBED = {
    "G.8262.1": "eEEC wander generation",
    "G.813": "SEC wander generation",
    "G.812": "SSU types I-VI wander generation",
    "G.823": "network limits for wander, 2048 kbit/s hierarchy",
    "G.824": "network limits for wander, 1544 kbit/s hierarchy",
}
