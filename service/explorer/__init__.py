"""Static files of the design explorer page (served by service/routes/explorer.py)."""
