# Thin wrappers around dev.py, which needs only Python 3.11+ and pip.
PYTHON ?= python3
.PHONY: demo test bench setup clean
demo:
	$(PYTHON) dev.py demo
test:
	$(PYTHON) dev.py test
bench:
	$(PYTHON) dev.py bench
setup:
	$(PYTHON) dev.py setup
clean:
	rm -rf .venv seawatch-demo build *.egg-info
