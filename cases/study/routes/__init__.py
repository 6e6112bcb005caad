"""The one runner of study files: the dispatch on a study's `[runner] route` (``dispatch``), the general
route, the sand route (``sand`` and its studies ``sand_study``) and the pressuremeter route (``sbp``)."""
