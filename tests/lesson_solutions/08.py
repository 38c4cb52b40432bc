# Reference solution of lesson 08 (injected in place of the exercise cell by the tests).
# ruff: noqa: F821  (fly and np come from the lesson's earlier cells)
seconds_flown, altitude = fly(altitude=60)
climb_time = float(seconds_flown[np.argmax(np.abs(altitude - 60) <= 1)])
