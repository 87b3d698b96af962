!> The parameter map: which entries of theta are free, which are tied to
!> a free one (theta(k) := theta(j)), and to which block each moving entry
!> belongs.  Sensitivities are kept per free parameter; a tied entry adds
!> its effect to its owner's column.
module mlid_params
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: layout_t
  implicit none
  private
  public :: param_map_t, param_map_create, apply_ties

  type :: param_map_t
    type(layout_t) :: l
    integer :: nf = 0
    integer, allocatable :: ifree(:)            !< theta index of each free parameter
    integer, allocatable :: tie(:)              !< tie(k) = j: theta(k) := theta(j); 0 if untied
    !> Moving entries by block: the index within the block and the free column.
    integer, allocatable :: im(:), cm(:)        !< model parameters p
    integer, allocatable :: ix0(:), cx0(:)      !< initial states (segment by segment)
    integer, allocatable :: ib(:), cb(:)        !< output biases (segment by segment)
    integer, allocatable :: iq(:), cq(:)        !< process-noise variances
    integer, allocatable :: ir(:), cr(:)        !< measurement-noise variances
    integer, allocatable :: is(:), cs(:)        !< cross-covariances
  end type param_map_t

contains

  !> Check the free flags and ties and build the map.
  subroutine param_map_create(l, isfree, itie, pm, status, msg)
    type(layout_t), intent(in) :: l
    integer, intent(in) :: isfree(:), itie(:)
    type(param_map_t), intent(out) :: pm
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k, j, col
    integer, allocatable :: act(:), acol(:)

    status = MLID_ERR_INPUT
    pm%l = l
    if (size(isfree) /= l%nth .or. size(itie) /= l%nth) then
      write (msg, '(a,i0)') 'free and tie arrays must have nth entries: ', l%nth
      return
    end if
    if (any(isfree /= 0 .and. isfree /= 1)) then
      msg = 'free flags must be 0 or 1'
      return
    end if
    do k = 1, l%nth
      j = itie(k)
      if (j == 0) cycle
      if (j < 0 .or. j > l%nth .or. j == k) then
        write (msg, '(a,i0,a,i0)') 'parameter ', k, ' is tied to a parameter that does not exist: ', j
        return
      else if (isfree(k) == 1) then
        write (msg, '(a,i0,a)') 'parameter ', k, ' is both free and tied'
        return
      else if (itie(j) /= 0) then
        write (msg, '(a,i0,a,i0,a)') 'parameter ', k, ' is tied to ', j, &
          ' which is itself tied: tie to the free parameter'
        return
      end if
    end do
    pm%tie = itie
    pm%ifree = pack([(k, k=1, l%nth)], isfree == 1)
    pm%nf = size(pm%ifree)
    ! moving entries: the free ones, then those tied to a free one
    allocate (act(0), acol(0))
    do k = 1, l%nth
      col = 0
      if (isfree(k) == 1) then
        col = findloc(pm%ifree, k, 1)
      else if (itie(k) /= 0) then
        if (isfree(itie(k)) == 1) col = findloc(pm%ifree, itie(k), 1)
      end if
      if (col > 0) then
        act = [act, k]
        acol = [acol, col]
      end if
    end do
    call block(0, l%np, pm%im, pm%cm)
    call block(l%ox0, l%nx*l%nseg, pm%ix0, pm%cx0)
    call block(l%obias, l%ny*l%nseg, pm%ib, pm%cb)
    call block(l%oq, l%nw, pm%iq, pm%cq)
    call block(l%or, l%ny, pm%ir, pm%cr)
    call block(l%os, l%nw*l%ny, pm%is, pm%cs)
    status = MLID_OK
    msg = ''

  contains

    subroutine block(offset, n, idx, cols)
      integer, intent(in) :: offset, n
      integer, allocatable, intent(out) :: idx(:), cols(:)
      logical :: in(size(act))
      in = act > offset .and. act <= offset + n
      idx = pack(act, in) - offset
      cols = pack(acol, in)
    end subroutine block

  end subroutine param_map_create

  !> theta(k) := theta(tie(k)) for every tied entry.
  pure subroutine apply_ties(tie, theta)
    integer, intent(in) :: tie(:)
    real(wp), intent(inout) :: theta(:)
    integer :: k
    do k = 1, size(tie)
      if (tie(k) /= 0) theta(k) = theta(tie(k))
    end do
  end subroutine apply_ties

end module mlid_params
