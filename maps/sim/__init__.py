"""The simulator: generated floor plans (floorplan.py), a laser (laser.py) and a robot that
wanders through every room (exploration.py). The demo, the benchmarks and the tests use it; the
package ``maps`` exports its public names."""
