# Reference solution of lesson 07 (injected in place of the exercise cell by the tests).
# ruff: noqa: F821  (batched_seconds and AUTO_COMPILE_SECONDS come from the lesson's cells)
low, high = 1, 10**9  # batched_seconds grows with agents: bisect for the first that reaches it
while low < high:
    middle = (low + high) // 2
    if batched_seconds(middle, 4000) >= AUTO_COMPILE_SECONDS:
        high = middle
    else:
        low = middle + 1
agents = low
