"""REST API (FastAPI): one router per resource under api/routes/, storage in api/store.py."""
