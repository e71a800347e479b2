bench:
	scripts/dev bench

test:
	scripts/dev test

.PHONY: bench test
