"""The levels of tracecheck's statistics, named once: every interval is at
:data:`CONFIDENCE`, and a paired comparison is called significant below
:data:`SIGNIFICANCE`.

>>> CONFIDENCE, round(1 - (1 - CONFIDENCE) / 2, 3)
(0.95, 0.975)
"""

__all__ = ["CONFIDENCE", "SIGNIFICANCE"]

#: the confidence level of every interval (metrics' t intervals, properties' Wilson or
#: Clopper-Pearson intervals, continuous actions' shares)
CONFIDENCE = 0.95
#: the p-value below which a paired comparison of two runs is called significant
SIGNIFICANCE = 0.05
