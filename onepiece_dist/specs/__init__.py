"""Every frozen spec the CLI or the API hands down to the workers: the job's (``job``), its labelling rules
(``labels``), planning and the pick benchmark's (``plan``), on one base (``frozen``)."""
