# Reference solution of lesson 02 (injected in place of the exercise cell by the tests).
root_statuses = ["RUNNING", "RUNNING", "RUNNING", "SUCCESS", "RUNNING"]
