!> State estimation along a record, and the sensitivity recursions.
!>
!> With no process noise the Kalman gain is zero and the filter reduces to
!> the output-error predictor (report §4.4): the model is integrated from
!> x0 and the innovations are the output errors.  This module holds that
!> predictor with its output sensitivities (eqs 4.31, 4.35 with K = 0).
module mlid_filter
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_DIVERGED
  use mlid_models, only: model_t
  use mlid_options, only: options_t
  use mlid_rk, only: rk4_step
  implicit none
  private
  public :: oe_predict

contains

  !> Model outputs yhat(ny, nt) along the record and, if dy is present,
  !> their sensitivities dy(ny, nf, nt) to the free parameters.
  !>
  !> theta = [p, x0, bias]; ifree holds the ascending indices into theta of
  !> the nf free parameters.  xhist(nx, nt), if present, receives the states.
  subroutine oe_predict(m, theta, ifree, t, u, opt, yhat, status, msg, dy, xhist)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    integer, intent(in) :: ifree(:)
    real(wp), intent(in) :: t(:), u(:, :)
    type(options_t), intent(in) :: opt
    real(wp), intent(out) :: yhat(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(out), optional :: dy(:, :, :)
    real(wp), intent(out), optional :: xhist(:, :)
    integer :: np, nx, ny, nt, nf, nm, j, k, q, isub
    integer, allocatable :: idxm(:)
    real(wp), allocatable :: s(:, :), c(:, :), d(:, :)
    real(wp) :: x(m%nx), ua(m%nu), ub(m%nu), h, ts
    logical :: sens

    status = MLID_OK
    msg = ''
    np = m%np
    nx = m%nx
    ny = m%ny
    nt = size(t)
    nf = size(ifree)
    sens = present(dy)
    idxm = pack(ifree, ifree <= np)
    nm = size(idxm)
    x = theta(np + 1:np + nx)
    if (sens) then
      allocate (s(nx, nf), c(ny, nx), d(ny, nm))
      s = 0.0_wp
      do k = 1, nf
        q = ifree(k) - np
        if (q >= 1 .and. q <= nx) s(q, k) = 1.0_wp   ! d x(0) / d x0(q)
      end do
    end if

    do j = 1, nt
      if (j > 1) then
        h = (t(j) - t(j - 1))/opt%substeps
        do isub = 1, opt%substeps
          ts = t(j - 1) + (isub - 1)*h
          if (opt%hold) then
            ua = u(:, j - 1)
            ub = ua
          else
            ua = u(:, j - 1) + (u(:, j) - u(:, j - 1))*(real(isub - 1, wp)/opt%substeps)
            ub = u(:, j - 1) + (u(:, j) - u(:, j - 1))*(real(isub, wp)/opt%substeps)
          end if
          if (sens) then
            call rk4_step(m, theta(1:np), ts, h, ua, ub, x, idxm, s)
          else
            call rk4_step(m, theta(1:np), ts, h, ua, ub, x, idxm)
          end if
        end do
        if (.not. all(ieee_is_finite(x))) then
          status = MLID_ERR_DIVERGED
          write (msg, '(a,g0.6,a)') 'simulation diverged: state non-finite at t = ', t(j), &
            ' (unstable model or parameters far off)'
          return
        end if
      end if
      if (present(xhist)) xhist(:, j) = x
      call m%h(t(j), x, u(:, j), theta(1:np), yhat(:, j))
      yhat(:, j) = yhat(:, j) + theta(np + nx + 1:np + nx + ny)
      if (sens) then
        call m%dhdx(t(j), x, u(:, j), theta(1:np), c)
        dy(:, :, j) = matmul(c, s)
        if (nm > 0) then
          call m%dhdp(t(j), x, u(:, j), theta(1:np), idxm, d)
          dy(:, 1:nm, j) = dy(:, 1:nm, j) + d
        end if
        do k = 1, nf
          q = ifree(k) - np - nx
          if (q >= 1) dy(q, k, j) = dy(q, k, j) + 1.0_wp   ! d y / d bias(q)
        end do
      end if
    end do
  end subroutine oe_predict

end module mlid_filter
