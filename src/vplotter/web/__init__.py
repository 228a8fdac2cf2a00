"""The page on the Pi (`vplotter serve`): a Starlette app served by uvicorn.

web/ knows HTTP (routes, the token, the upload folder, the page's files in static/); what it
does to the plotter it asks of a `machine` object that commands/serve.py makes from the CLI's
own code (status, estimate, preview, the file options, and `draw --detach`, `stop`, `pen`,
`jog`, `calibrate --at`, `home` as subprocesses), so that the page and the terminal are the
same machinery. Starlette, uvicorn and python-multipart are imported only here (`vplotter
--help` stays fast).
"""
