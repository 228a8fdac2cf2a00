from vplotter.cli import run

run()
